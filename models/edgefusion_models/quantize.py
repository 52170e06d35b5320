"""Post-training quantisation: float IR (graph.py) + calibration images -> int8 model (qmodel.py).

Choices (docs/model_format.md fixes the arithmetic, these are the exporter's):
- Activations: per tensor, asymmetric int8 with a zero point, from the min / max observed over the
  calibration images (always including 0, so that zero padding is exact). Layers with an output range
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


def calibrate(g: Graph, raw_frames, in_range, batch=8):
    """{tensor: (min, max)} over raw frames N x H x W x C. The normalised input is clipped to the
    input tensor's range first, as the int8 input saturates."""
    obs = RangeObserver()
    for i in range(0, len(raw_frames), batch):
        x = np.clip(normalise(g, raw_frames[i:i + batch]), np.float32(in_range[0]), np.float32(in_range[1]))
        forward(g, x, observer=obs)
    return obs.ranges


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


def correct_biases(g: Graph, raw_frames, ranges, depth_max=DEFAULT_DEPTH_MAX_M, concat_policy="share"):
    """Empirical bias correction (Nagel et al., "Data-Free Quantization Through Weight Equalization and
    Bias Correction", ICCV 2019, section 4.2, with data): quantisation errors of the weights and of
    the activations shift each convolution's output on average, and a network deep enough adds those
    shifts up. Layer by layer in order, the calibration frames go through the float graph and
    through a simulation of the int8 one (weights as quantize_conv makes them, every tensor rounded
    onto its int8 grid); each convolution's bias loses the mean difference of its pre-activation
    outputs per channel, before the next layer is simulated. Changes g's biases in place."""
    in_range = input_range(g, depth_max)
    params = activation_params(g, ranges, in_range, concat_policy)
    x = np.clip(normalise(g, raw_frames), np.float32(in_range[0]), np.float32(in_range[1]))
    fl = {g.input: x}
    qu = {g.input: _fake_quant(x, *params[g.input])}
    last_use = {}
    for i, n in enumerate(g.nodes):
        for t in n.inputs:
            last_use[t] = i
    for i, n in enumerate(g.nodes):
        f_in = [fl[t] for t in n.inputs]
        q_in = [qu[t] for t in n.inputs]
        if n.kind in CONV_KINDS:
            s_in = params[n.inputs[0]][0]
            s_out = params[n.output][0]
            scales, _, qw = quantize_conv(n.weight, n.bias, s_in, s_out, n.weight_scale)
            wq = (qw.reshape(n.weight.shape[0], -1).astype(np.float64) * scales.astype(np.float64)[:, None])
            linear = Node(**{**n.__dict__, "act_range": (-INF, INF)})
            f_pre = run_node(linear, f_in)
            linear.weight = wq.reshape(n.weight.shape).astype(np.float32)
            q_pre = run_node(linear, q_in)
            shift = (q_pre.astype(np.float64) - f_pre).reshape(-1, f_pre.shape[-1]).mean(axis=0)
            n.bias = (n.bias.astype(np.float64) - shift).astype(np.float32)
            linear.bias = n.bias
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


def quantize(g: Graph, raw_frames, depth_max=DEFAULT_DEPTH_MAX_M, concat_policy="share", name=None,
             bias_correction=False):
    """Calibrates on raw frames (N x H x W x C: R, G, B 0..255, depth metres) and quantises.
    bias_correction: correct_biases() on the same frames first (the TFLite importer's default)."""
    ranges = calibrate(g, raw_frames, input_range(g, depth_max))
    if bias_correction:
        correct_biases(g, raw_frames, ranges, depth_max, concat_policy)
    return quantize_graph(g, ranges, depth_max, concat_policy, name)
