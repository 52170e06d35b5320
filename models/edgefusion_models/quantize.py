"""Post-training quantisation: float IR (graph.py) + calibration images -> int8 model (qmodel.py).

Choices (docs/model_format.md fixes the arithmetic, these are the exporter's):
- Activations: per tensor, asymmetric int8 with a zero point, from the min / max observed over the
  calibration images (always including 0, so that zero padding is exact), or (clip="mse", the TFLite
  importer's) the clip inside them that minimises the tensor's expected squared quantisation error
  on the calibration images' histogram: a few extreme values then no longer coarsen every other
  value's step. Layers with an output range
  (ReLU6: [0, 6]) only ever produce values inside it, so their range is [0, 6] clipped to what was
  observed. Range ends are rounded outward to 8 significant bits first: a last-bit difference in the
  float forward pass (another BLAS, another CPU) then almost never changes a scale, which keeps the
  exported bytes reproducible.
- Tensors that the format requires to share one quantisation (upsample, resize_bilinear, clamp and
  max_pool in/out)
  form groups (union-find) quantised with the union of their members' ranges. Concat inputs join their
  output's group too (policy "share", the default): each value is then rounded once, by the layer
  that produced it, and the concat is an exact copy; "requantize" keeps separate input ranges.
- The input tensor's range is the image of the raw value domain (R, G, B in [0, 255], depth in
  [0, depth_max] metres) under the normalisation mean / scale: for EdgeSegNet [-1, 1].
- Weights: symmetric per output channel in [-127, 127], scale = max |w| / 127; biases int32 in units
  of input_scale * weight_scale. A channel whose bias would exceed 2^30 units gets a larger weight
  scale instead (never needed by sane networks, kept so that export cannot fail on it).
"""
import math

import numpy as np

from .graph import CONV_KINDS, INF, Graph, Node, forward, infer_shapes, normalise, run_node
from .netconst import DEPTH_MAX_M
from .qmodel import (Activation, DType, LayerType, MAX_ABS_BIAS, FLT_MIN, ModelError, QLayer, QModel, QTensor,
                     UpsampleMode, f32, validate)

RGB_RANGE = (0.0, 255.0)
DEFAULT_DEPTH_MAX_M = DEPTH_MAX_M  # metres
MIN_SPAN = 2.0 ** -10   # real units; the range of a tensor that is 0 everywhere
SIGNIFICANT_BITS = 8    # range ends are rounded outward to this many bits


# ----------------------------------------------------------------------------------------------
# Calibration

class RangeObserver:
    """Running min / max of every tensor over the calibration batches."""

    def __init__(self):
        self.ranges = {}

    def __call__(self, name, arr):
        lo, hi = float(arr.min()), float(arr.max())
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise ValueError(f"calibration: tensor '{name}' has non-finite values")
        old = self.ranges.get(name)
        self.ranges[name] = (lo, hi) if old is None else (min(old[0], lo), max(old[1], hi))


def raw_domain(channels, depth_max=DEFAULT_DEPTH_MAX_M):
    """Per input channel (lo, hi) of the raw values: R, G, B then depth (docs, META)."""
    return [RGB_RANGE] * (channels - 1) + [(0.0, float(depth_max))] if channels == 4 else [RGB_RANGE] * channels


def input_range(g: Graph, depth_max=DEFAULT_DEPTH_MAX_M):
    """The real range of the normalised input: the raw domain through (v - mean) * scale."""
    ends = []
    for (lo, hi), m, s in zip(raw_domain(g.input_shape[2], depth_max), g.mean, g.scale):
        ends += [(lo - f32(m)) * f32(s), (hi - f32(m)) * f32(s)]
    return min(ends), max(ends)


HISTOGRAM_BINS = 4096  # per tensor, over its observed [min, max] widened to include 0
CLIP_STEPS = 200       # clip ends searched at k / CLIP_STEPS of the observed ends, k = 1..CLIP_STEPS


class HistogramObserver:
    """Per tensor, a histogram of HISTOGRAM_BINS equal bins over its known range (min and max from a
    first pass, widened to include 0), summed over the calibration batches."""

    def __init__(self, ranges):
        self.ranges = ranges
        self.counts = {}

    def __call__(self, name, arr):
        lo, hi = histogram_span(self.ranges[name])
        c, _ = np.histogram(arr.reshape(-1), bins=HISTOGRAM_BINS, range=(lo, hi))
        self.counts[name] = self.counts.get(name, 0) + c.astype(np.int64)


def histogram_span(rng):
    lo, hi = min(rng[0], 0.0), max(rng[1], 0.0)
    return lo, (hi if hi > lo else lo + 1e-6)


def quant_mse(counts, centers, lo, hi):
    """The expected squared error of quantising the histogram's values onto the int8 grid of the
    range [lo, hi] (widened to include 0): the rounding noise s^2 / 12 inside, the squared distance
    to the nearer end outside."""
    lo, hi = min(lo, 0.0), max(hi, 0.0)
    s = (hi - lo) / 255.0
    inside = (centers >= lo) & (centers <= hi)
    err = np.where(inside, s * s / 12.0, np.where(centers < lo, (centers - lo) ** 2, (centers - hi) ** 2))
    return float((counts * err).sum() / counts.sum())


def mse_clip(counts, edges):
    """(lo, hi): the clip of a tensor's range that minimises quant_mse on its histogram (bin counts,
    bin edges). Each end is searched on CLIP_STEPS fractions of the observed end, by coordinate descent
    (hi, then lo; three rounds); the observed range is kept when nothing beats it."""
    centers = 0.5 * (edges[:-1] + edges[1:])
    nz = np.nonzero(counts)[0]
    o_lo, o_hi = min(float(edges[nz[0]]), 0.0), max(float(edges[nz[-1] + 1]), 0.0)
    fr = np.linspace(1.0 / CLIP_STEPS, 1.0, CLIP_STEPS)
    his = o_hi * fr if o_hi > 0 else np.array([0.0])
    los = o_lo * fr if o_lo < 0 else np.array([0.0])
    best = (quant_mse(counts, centers, o_lo, o_hi), o_lo, o_hi)
    lo, hi = o_lo, o_hi
    for _ in range(3):
        hi = float(his[int(np.argmin([quant_mse(counts, centers, lo, h) for h in his]))])
        lo = float(los[int(np.argmin([quant_mse(counts, centers, l, hi) for l in los]))])
    e = quant_mse(counts, centers, lo, hi)
    return (lo, hi) if e < best[0] else (best[1], best[2])


def calibrate(g: Graph, raw_frames, in_range, batch=8, clip="minmax"):
    """{tensor: (min, max)} over raw frames N x H x W x C. The normalised input is clipped to the
    input tensor's range first, as the int8 input saturates. clip="mse": a second pass histograms
    every tensor, and each range (but the input's, which the raw domain fixes) becomes its mse_clip."""
    if clip not in ("minmax", "mse"):
        raise ValueError(f"calibration: clip '{clip}' is not minmax or mse")
    obs = RangeObserver()
    batches = [np.clip(normalise(g, raw_frames[i:i + batch]), np.float32(in_range[0]), np.float32(in_range[1]))
               for i in range(0, len(raw_frames), batch)]
    for x in batches:
        forward(g, x, observer=obs)
    if clip == "minmax":
        return obs.ranges
    hist = HistogramObserver(obs.ranges)
    for x in batches:
        forward(g, x, observer=hist)
    out = dict(obs.ranges)
    for t, c in hist.counts.items():
        if t != g.input:
            lo, hi = histogram_span(obs.ranges[t])
            out[t] = mse_clip(c, np.linspace(lo, hi, HISTOGRAM_BINS + 1))
    return out


def integer_input_mean(g: Graph):
    """Makes the normalisation mean of every colour channel an integer, so that the int8 input is exact.

    With mean 127.5 and scale 1 / 127.5 (DeepLab's v / 127.5 - 1), (v - 127.5) / 127.5 lies half-way
    between two steps of any int8 grid that spans 0..255: the input rounds every pixel by half a step
    (4e-3), away from zero, a systematic error the whole network sees. With mean 128 the input is
    (v - 128) / 127.5, exactly q = v - 128 on the grid of step 1 / 127.5 and zero point 0. The
    difference, (128 - 127.5) / 127.5 per channel, goes into the bias of the one convolution that reads
    the input, which then computes what it computed before everywhere except where its window overlaps
    the zero padding (the border rows and columns of its output, where the padding now stands for
    v = 128 instead of v = 127.5). Means are rounded half up; a depth channel (or a graph whose input
    has another reader than one convolution) is left as it is. Changes g in place; returns it."""
    readers = [n for n in g.nodes if g.input in n.inputs]
    channels = g.input_shape[2] - (1 if g.input_shape[2] == 4 else 0)  # R, G, B; not depth
    new_mean = [math.floor(m + 0.5) if c < channels else m for c, m in enumerate(g.mean)]
    if new_mean == list(g.mean) or len(readers) != 1 or readers[0].kind != "conv2d" or readers[0].inputs != [g.input]:
        return g
    n = readers[0]
    delta = np.array([(f32(nm) - f32(m)) * f32(s) for nm, m, s in zip(new_mean, g.mean, g.scale)], np.float64)
    n.bias = (n.bias.astype(np.float64) + np.einsum("oyxc,c->o", n.weight.astype(np.float64), delta)).astype(np.float32)
    g.mean = [float(v) for v in new_mean]
    return g


# ----------------------------------------------------------------------------------------------
# Activation quantisation parameters

def _round_outward(v):
    """v rounded away from zero to SIGNIFICANT_BITS significant bits."""
    if v == 0:
        return 0.0
    _, e = math.frexp(abs(v))
    step = 2.0 ** (e - SIGNIFICANT_BITS)
    return math.copysign(math.ceil(abs(v) / step) * step, v)


def qparams(lo, hi, round_ends=True):
    """(scale float32, zero point) covering [lo, hi] widened to include 0."""
    lo, hi = min(lo, 0.0), max(hi, 0.0)
    if round_ends:
        lo, hi = _round_outward(lo), _round_outward(hi)
    if hi - lo < MIN_SPAN:
        hi = lo + MIN_SPAN
    scale = f32((hi - lo) / 255.0)
    zp = int(np.clip(np.rint(-128.0 - lo / scale), -128, 127))
    return scale, zp


class _Groups:
    """Union-find of tensors that must share one quantisation."""

    def __init__(self):
        self.parent = {}

    def find(self, t):
        self.parent.setdefault(t, t)
        while self.parent[t] != t:
            self.parent[t] = self.parent[self.parent[t]]
            t = self.parent[t]
        return t

    def union(self, a, b):
        ra, rb = self.find(a), self.find(b)
        if ra != rb:
            self.parent[rb] = ra


def activation_params(g: Graph, ranges, in_range, concat_policy="share"):
    """{tensor: (scale, zero point)} for every int8 tensor."""
    groups = _Groups()
    for n in g.nodes:
        if n.kind in ("upsample", "resize_bilinear", "clamp", "max_pool") or (
                n.kind == "concat" and concat_policy == "share"):
            for t in n.inputs:
                groups.union(n.output, t)
    # Each tensor's own range: observed, inside the producer's output range; the input's from the domain.
    own = {g.input: in_range}
    for n in g.nodes:
        if n.kind == "softmax":
            continue
        if n.output not in ranges:
            raise ValueError(f"calibration: tensor '{n.output}' was never observed")
        lo, hi = ranges[n.output]
        a_lo, a_hi = n.act_range
        own[n.output] = (max(lo, a_lo) if a_lo > -INF else lo, min(hi, a_hi) if a_hi < INF else hi)
    union = {}
    for t, (lo, hi) in own.items():
        r = groups.find(t)
        old = union.get(r)
        union[r] = (lo, hi) if old is None else (min(old[0], lo), max(old[1], hi))
    params = {}
    for r, (lo, hi) in union.items():
        # The input's range is exact by construction: no outward rounding (it sets the input's scale).
        exact = all(groups.find(t) != r for t in own if t != g.input) and groups.find(g.input) == r
        params[r] = qparams(lo, hi, round_ends=not exact)
    return {t: params[groups.find(t)] for t in own}


# ----------------------------------------------------------------------------------------------
# Layers

def _round_half_away(v):
    return math.floor(v + 0.5) if v >= 0 else -math.floor(-v + 0.5)


def out_range(act_range, scale, zp):
    """The integer [out_min, out_max] of an output range in real units (docs 3.2): none ->
    [-128, 127]; ReLU -> [max(-128, z), 127]; ReLU6 -> [max(-128, z), min(127, z + round(6 / s))]."""
    lo_r, hi_r = act_range
    lo = -128 if lo_r == -INF else max(-128, min(127, zp + _round_half_away(lo_r / scale)))
    hi = 127 if hi_r == INF else min(127, max(-128, zp + _round_half_away(hi_r / scale)))
    return lo, max(lo, hi)


def activation_label(act_range):
    lo, hi = act_range
    if (lo, hi) == (-INF, INF):
        return Activation.NONE
    if (lo, hi) == (0.0, INF):
        return Activation.RELU
    if (lo, hi) == (0.0, 6.0):
        return Activation.RELU6
    return Activation.CLAMP


def quantize_conv(weight, bias, s_in, s_out, grid=None):
    """(weight_scales float32 [Cout], bias int32 [Cout], weights int8 flat) of one convolution.
    grid: per output channel, the scale of an int8 grid the weights already lie on (imported int8
    weights); used as the channel's scale when every weight is within [-127, 127] steps of it, so the
    imported integers are kept exactly (another grid would round them a second time)."""
    cout = weight.shape[0]
    w = weight.reshape(cout, -1).astype(np.float64)
    b = bias.astype(np.float64)
    s_in, s_out = f32(s_in), f32(s_out)
    scales = np.zeros(cout, np.float32)
    qb = np.zeros(cout, np.int32)
    qw = np.zeros(w.shape, np.int8)
    for o in range(cout):
        amax = float(np.abs(w[o]).max())
        ws = np.float32(max(amax / 127.0 if amax > 0 else 1.0 / 127.0,
                            4.0 * FLT_MIN * s_out / s_in))  # the multiplier stays a normal float32
        if grid is not None and grid[o] > 0 and amax / float(grid[o]) <= 127.0 + 1e-3:
            ws = np.float32(max(float(grid[o]), 4.0 * FLT_MIN * s_out / s_in))
        bq = np.rint(b[o] / (s_in * float(ws)))
        if abs(bq) > MAX_ABS_BIAS:  # the bias dominates: a coarser weight scale keeps it within 2^30 units
            ws = np.float32(abs(b[o]) / (s_in * (MAX_ABS_BIAS - 1)))
            while abs(np.rint(b[o] / (s_in * float(ws)))) > MAX_ABS_BIAS:
                ws = np.nextafter(ws, np.float32(np.inf))
            bq = np.rint(b[o] / (s_in * float(ws)))
        scales[o] = ws
        qw[o] = np.clip(np.rint(w[o] / float(ws)), -127, 127).astype(np.int8)
        qb[o] = int(bq)
    return scales, qb, qw.reshape(-1)


_CONV_TYPE = {"conv2d": LayerType.CONV2D, "depthwise_conv2d": LayerType.DEPTHWISE_CONV2D,
              "pointwise_conv2d": LayerType.POINTWISE_CONV2D}


def quantize_graph(g: Graph, ranges, depth_max=DEFAULT_DEPTH_MAX_M, concat_policy="share", name=None):
    """The QModel of graph g with calibration ranges {tensor: (min, max)} (calibrate())."""
    shapes = infer_shapes(g)
    in_range = input_range(g, depth_max)
    params = activation_params(g, ranges, in_range, concat_policy)
    ids, tensors, names = {}, [], []

    def add_tensor(t, dtype=DType.INT8):
        h, w, c = shapes[t]
        s, z = params[t] if dtype == DType.INT8 else (1.0, 0)
        ids[t] = len(tensors)
        tensors.append(QTensor(h=h, w=w, c=c, scale=s, zero_point=z, dtype=dtype))
        names.append(t)

    add_tensor(g.input)
    layers = []
    for n in g.nodes:
        where = f"{g.name}: node '{n.name}' ({n.kind})"
        add_tensor(n.output, DType.FLOAT32 if n.kind == "softmax" else DType.INT8)
        out = tensors[ids[n.output]]
        l = QLayer(type=LayerType.SOFTMAX, inputs=[ids[t] for t in n.inputs], output=ids[n.output], name=n.name)
        if n.kind in CONV_KINDS:
            t_in = tensors[ids[n.inputs[0]]]
            l.type = _CONV_TYPE[n.kind]
            l.kernel_h, l.kernel_w = n.kernel
            l.stride_h, l.stride_w = n.stride
            l.dilation_h, l.dilation_w = n.dilation
            l.pad_top, l.pad_left, l.pad_bottom, l.pad_right = n.pads
            l.weight_scales, l.bias, l.weights = quantize_conv(n.weight, n.bias, t_in.scale, out.scale,
                                                               n.weight_scale)
        elif n.kind in ("max_pool", "avg_pool"):
            l.type = LayerType.MAX_POOL if n.kind == "max_pool" else LayerType.AVG_POOL
            l.kernel_h, l.kernel_w = n.kernel
            l.stride_h, l.stride_w = n.stride
            l.pad_top, l.pad_left, l.pad_bottom, l.pad_right = n.pads
        elif n.kind == "upsample":
            l.type = LayerType.UPSAMPLE
            l.factor = n.factor
            l.mode = UpsampleMode.BILINEAR if n.mode == "bilinear" else UpsampleMode.NEAREST
        elif n.kind == "resize_bilinear":
            l.type = LayerType.RESIZE_BILINEAR  # the output size is the output tensor's
        elif n.kind in ("add", "concat", "clamp"):
            l.type = {"add": LayerType.ADD, "concat": LayerType.CONCAT, "clamp": LayerType.CLAMP}[n.kind]
        elif n.kind != "softmax":
            raise ModelError(f"{where}: no int8 layer for this kind (fold or remove it first)")
        if n.kind in CONV_KINDS + ("add", "clamp"):
            l.out_min, l.out_max = out_range(n.act_range, out.scale, out.zero_point)
            l.act = activation_label(n.act_range)
        layers.append(l)
    classes = list(g.class_names) or [f"class{i}" for i in range(shapes[g.output][2])]
    m = QModel(name=name or g.name, input_tensor=ids[g.input], output_tensor=ids[g.output],
               input_mean=[f32(v) for v in g.mean], input_scale=[f32(v) for v in g.scale], class_names=classes,
               tensors=tensors, layers=layers, tensor_names=names, class_map=[int(k) for k in g.class_map],
               target_class_names=list(g.target_class_names))
    validate(m)
    return m


def _fake_quant(y, scale, zp):
    """y rounded onto the int8 grid of (scale, zero point) and back to real units (3.0, 3.1)."""
    s = float(scale)
    return ((np.clip(np.rint(y / s) + zp, -128, 127) - zp) * s).astype(np.float32)


GAIN_LIMIT = 0.1  # the gain correction changes a channel's scale by at most this fraction


def _quantized_weights(n: Node, s_in, s_out):
    """The weights of convolution n as quantize_conv puts them on their int8 grid, in real units."""
    scales, _, qw = quantize_conv(n.weight, n.bias, s_in, s_out, n.weight_scale)
    wq = qw.reshape(n.weight.shape[0], -1).astype(np.float64) * scales.astype(np.float64)[:, None]
    return wq.reshape(n.weight.shape).astype(np.float32)


def correct_biases(g: Graph, raw_frames, ranges, depth_max=DEFAULT_DEPTH_MAX_M, concat_policy="share", gain=False):
    """Empirical bias correction (Nagel et al., "Data-Free Quantization Through Weight Equalization and
    Bias Correction", ICCV 2019, section 4.2, with data): quantisation errors of the weights and of
    the activations shift each convolution's output on average, and a network deep enough adds those
    shifts up. Layer by layer in order, the calibration frames go through the float graph and
    through a simulation of the int8 one (weights as quantize_conv makes them, every tensor rounded
    onto its int8 grid); each convolution's bias loses the mean difference of its pre-activation
    outputs per channel, before the next layer is simulated. Changes g's biases in place.

    gain: first, each output channel's weights are scaled so that the standard deviation of its
    simulated int8 pre-activation output equals the float one's (the quantisation of its inputs
    shrinks or swells it; cf. Banner et al., "Post training 4-bit quantization of convolutional
    networks", NeurIPS 2019, bias and variance correction), within 1 +- GAIN_LIMIT. The channel's int8
    grid (Node.weight_scale) is scaled with it, so imported integers stay exactly what they were and
    only their per-channel scale changes. Changes g's weights and grids in place; returns
    {node name: gains}."""
    in_range = input_range(g, depth_max)
    params = activation_params(g, ranges, in_range, concat_policy)
    x = np.clip(normalise(g, raw_frames), np.float32(in_range[0]), np.float32(in_range[1]))
    fl = {g.input: x}
    qu = {g.input: _fake_quant(x, *params[g.input])}
    last_use = {}
    for i, n in enumerate(g.nodes):
        for t in n.inputs:
            last_use[t] = i
    gains = {}
    for i, n in enumerate(g.nodes):
        f_in = [fl[t] for t in n.inputs]
        q_in = [qu[t] for t in n.inputs]
        if n.kind in CONV_KINDS:
            s_in = params[n.inputs[0]][0]
            s_out = params[n.output][0]
            linear = Node(**{**n.__dict__, "act_range": (-INF, INF)})
            f_pre = run_node(linear, f_in)
            if gain:
                linear.weight = _quantized_weights(n, s_in, s_out)
                linear.bias = np.zeros_like(n.bias)
                cout = f_pre.shape[-1]
                q0 = run_node(linear, q_in).astype(np.float64).reshape(-1, cout)
                f_std = f_pre.astype(np.float64).reshape(-1, cout).std(axis=0)
                a = np.clip(f_std / np.maximum(q0.std(axis=0), 1e-20), 1.0 - GAIN_LIMIT, 1.0 + GAIN_LIMIT)
                gains[n.name] = a
                n.weight = (n.weight.astype(np.float64) * a.reshape((-1,) + (1,) * (n.weight.ndim - 1))).astype(np.float32)
                if n.weight_scale is not None:
                    n.weight_scale = (n.weight_scale.astype(np.float64) * a).astype(np.float32)
                linear = Node(**{**n.__dict__, "act_range": (-INF, INF)})
            linear.weight = _quantized_weights(n, s_in, s_out)
            q_pre = run_node(linear, q_in)
            shift = (q_pre.astype(np.float64) - f_pre).reshape(-1, f_pre.shape[-1]).mean(axis=0)
            n.bias = (n.bias.astype(np.float64) - shift).astype(np.float32)
            q_pre = (q_pre - shift.astype(np.float32)).astype(np.float32)
            lo, hi = n.act_range
            f_out = np.clip(f_pre, np.float32(lo), np.float32(hi)) if (lo > -INF or hi < INF) else f_pre
            q_out = np.clip(q_pre, np.float32(lo), np.float32(hi)) if (lo > -INF or hi < INF) else q_pre
        else:
            f_out = run_node(n, f_in)
            q_out = run_node(n, q_in)
        fl[n.output] = f_out
        qu[n.output] = q_out if n.kind == "softmax" else _fake_quant(q_out, *params[n.output])
        for t in set(n.inputs):
            if last_use.get(t) == i and t != g.output:
                del fl[t], qu[t]
    return gains


def quantize(g: Graph, raw_frames, depth_max=DEFAULT_DEPTH_MAX_M, concat_policy="share", name=None,
             bias_correction=False, clip="minmax", gain_correction=False):
    """Calibrates on raw frames (N x H x W x C: R, G, B 0..255, depth metres) and quantises.
    bias_correction: correct_biases() on the same frames first (the TFLite importer's default), with
    its gain correction when gain_correction; clip: the activation ranges, calibrate()'s "minmax" or
    "mse"."""
    ranges = calibrate(g, raw_frames, input_range(g, depth_max), clip=clip)
    if bias_correction:
        correct_biases(g, raw_frames, ranges, depth_max, concat_policy, gain=gain_correction)
    elif gain_correction:
        raise ValueError("gain correction is part of the bias correction")
    return quantize_graph(g, ranges, depth_max, concat_policy, name)
