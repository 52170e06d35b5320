"""An independent float32 forward pass of a TFLite graph, operator by operator as the file spells it
(SPACE_TO_BATCH_ND, DEPTHWISE_CONV_2D, BATCH_TO_SPACE_ND, MUL, ADD, ... each on its own), in numpy.

It is the reference the importer (from_tflite.py, which folds and rewrites the graph) is checked
against: it shares no code with graph.py / float_ops.py. Each operator follows TensorFlow Lite's
reference kernels (tensorflow/lite/kernels/internal/reference/*.h): SAME padding puts the smaller
half before, average pooling divides by the number of positions inside the input, RESIZE_BILINEAR
with align_corners maps output o to input o * (in - 1) / (out - 1).

Input sizes other than the file's: the network is fully convolutional, but the file bakes its sizes
into constants (resize targets, the space-to-batch paddings, the global pool's window). With
`size=(H, W)` every such constant that is a spatial size d of the file's input S0 (513) is mapped to
(d - 1) * (S - 1) / (S0 - 1) + 1, per axis, and the space-to-batch paddings are recomputed by
TensorFlow's rule (the base padding plus what makes the padded size a multiple of the block). That
keeps DeepLab's alignment: H - 1 and W - 1 must be multiples of the output stride (8).
"""
from typing import Dict, Optional, Tuple

import numpy as np

from . import tflite

OUTPUT_STRIDE = 8


class RefError(ValueError):
    pass


def _act(x, name):
    if name == "NONE":
        return x
    if name == "RELU":
        return np.maximum(x, 0)
    if name == "RELU6":
        return np.clip(x, 0, 6)
    if name == "RELU_N1_TO_1":
        return np.clip(x, -1, 1)
    raise RefError(f"activation {name} not supported")


def same_pads(size, k, stride, dilation):
    """(out, before, after) of TensorFlow's SAME padding along one axis."""
    out = -(-size // stride)
    eff = (k - 1) * dilation + 1
    total = max((out - 1) * stride + eff - size, 0)
    return out, total // 2, total - total // 2


def _pad_for(x, kh, kw, stride, dil, padding):
    """x padded with zeros for a window op, and the output size."""
    _, h, w, _ = x.shape
    if padding == "SAME":
        oh, pt, pb = same_pads(h, kh, stride[0], dil[0])
        ow, pl, pr = same_pads(w, kw, stride[1], dil[1])
    elif padding == "VALID":
        oh = (h - (kh - 1) * dil[0] - 1) // stride[0] + 1
        ow = (w - (kw - 1) * dil[1] - 1) // stride[1] + 1
        pt = pb = pl = pr = 0
    else:
        raise RefError(f"padding {padding} not supported")
    if oh <= 0 or ow <= 0:
        raise RefError(f"window {kh}x{kw} larger than the input {h}x{w}")
    return np.pad(x, ((0, 0), (pt, pb), (pl, pr), (0, 0))), oh, ow, (pt, pl)


def _tap(xp, ky, kx, oh, ow, stride, dil):
    """The input under tap (ky, kx) for every output position: N x oh x ow x C."""
    y0, x0 = ky * dil[0], kx * dil[1]
    return xp[:, y0:y0 + (oh - 1) * stride[0] + 1:stride[0], x0:x0 + (ow - 1) * stride[1] + 1:stride[1], :]


def conv2d(x, w, b, stride, dil, padding, act):
    """x N x H x W x Cin, w [Cout, kh, kw, Cin] (OHWI), b [Cout]."""
    cout, kh, kw, cin = w.shape
    if x.shape[3] != cin:
        raise RefError(f"conv input has {x.shape[3]} channels, filter expects {cin}")
    xp, oh, ow, _ = _pad_for(x, kh, kw, stride, dil, padding)
    out = np.zeros((x.shape[0], oh, ow, cout), np.float32)
    for ky in range(kh):
        for kx in range(kw):
            out += _tap(xp, ky, kx, oh, ow, stride, dil) @ w[:, ky, kx, :].T
    return _act(out + b, act)


def depthwise(x, w, b, stride, dil, padding, act, multiplier):
    """x N x H x W x C, w [1, kh, kw, C * multiplier]."""
    _, kh, kw, cm = w.shape
    if multiplier != 1 or cm != x.shape[3]:
        raise RefError(f"depthwise with multiplier {multiplier} over {x.shape[3]} -> {cm} channels not supported")
    xp, oh, ow, _ = _pad_for(x, kh, kw, stride, dil, padding)
    out = np.zeros((x.shape[0], oh, ow, cm), np.float32)
    for ky in range(kh):
        for kx in range(kw):
            out += _tap(xp, ky, kx, oh, ow, stride, dil) * w[0, ky, kx, :]
    return _act(out + b, act)


def average_pool(x, fh, fw, stride, padding, act):
    """Mean over the window positions inside the input (TFLite excludes SAME padding from the count)."""
    ones = np.ones(x.shape[:3] + (1,), np.float32)
    xp, oh, ow, _ = _pad_for(x, fh, fw, stride, (1, 1), padding)
    cp, _, _, _ = _pad_for(ones, fh, fw, stride, (1, 1), padding)
    s = np.zeros((x.shape[0], oh, ow, x.shape[3]), np.float64)
    n = np.zeros((x.shape[0], oh, ow, 1), np.float64)
    for ky in range(fh):
        for kx in range(fw):
            s += _tap(xp, ky, kx, oh, ow, stride, (1, 1))
            n += _tap(cp, ky, kx, oh, ow, stride, (1, 1))
    return _act((s / n).astype(np.float32), act)


def space_to_batch(x, block, pads):
    """[N, H, W, C] -> [N * bh * bw, (H + p) / bh, (W + p) / bw, C]; batch index (by * bw + bx) * N + n."""
    bh, bw = block
    n, _, _, c = x.shape
    xp = np.pad(x, ((0, 0), tuple(pads[0]), tuple(pads[1]), (0, 0)))
    h, w = xp.shape[1], xp.shape[2]
    if h % bh or w % bw:
        raise RefError(f"padded size {h}x{w} not a multiple of the block {bh}x{bw}")
    y = xp.reshape(n, h // bh, bh, w // bw, bw, c).transpose(2, 4, 0, 1, 3, 5)
    return y.reshape(bh * bw * n, h // bh, w // bw, c)


def batch_to_space(x, block, crops):
    """The inverse of space_to_batch, then the crops removed."""
    bh, bw = block
    nb, h, w, c = x.shape
    n = nb // (bh * bw)
    y = x.reshape(bh, bw, n, h, w, c).transpose(2, 3, 0, 4, 1, 5).reshape(n, h * bh, w * bw, c)
    return y[:, crops[0][0]:h * bh - crops[0][1], crops[1][0]:w * bw - crops[1][1], :]


def resize_bilinear(x, out_h, out_w, align_corners, half_pixel):
    """TFLite RESIZE_BILINEAR (reference_ops::ResizeBilinear) in float."""
    def axis(out, size):
        o = np.arange(out, dtype=np.float64)
        if align_corners and out > 1:
            scale = (size - 1) / (out - 1)
        else:
            scale = size / out
        if half_pixel:
            src = (o + 0.5) * scale - 0.5
        else:
            src = o * scale
        i0 = np.floor(src).astype(np.int64)
        frac = src - i0
        lo = np.clip(i0, 0, size - 1)
        hi = np.clip(i0 + 1, 0, size - 1)
        return lo, hi, frac.astype(np.float32)
    y0, y1, fy = axis(out_h, x.shape[1])
    x0, x1, fx = axis(out_w, x.shape[2])
    top = x[:, y0] * (1 - fy)[None, :, None, None] + x[:, y1] * fy[None, :, None, None]
    return top[:, :, x0] * (1 - fx)[None, None, :, None] + top[:, :, x1] * fx[None, None, :, None]


class SizeMap:
    """Maps the file's spatial constants to another input size (module docstring)."""

    def __init__(self, file_hw: Tuple[int, int], hw: Tuple[int, int]):
        self.file_hw, self.hw = file_hw, hw
        for s, s0 in zip(hw, file_hw):
            if (s - 1) % OUTPUT_STRIDE or s < OUTPUT_STRIDE + 1:
                raise RefError(f"input size {hw[1]}x{hw[0]}: each side must be {OUTPUT_STRIDE}k + 1 "
                               f"(the network's alignment), e.g. 257, 321, 513")

    def dim(self, d, axis):
        s0, s = self.file_hw[axis], self.hw[axis]
        if (d - 1) * (s - 1) % (s0 - 1):
            raise RefError(f"size {d} of the file does not scale to input {s} (axis {axis})")
        return (d - 1) * (s - 1) // (s0 - 1) + 1


def _s2b_pads(size, block, base):
    """TensorFlow's required_space_to_batch_paddings on one axis: (pads, crops)."""
    extra = (block - (size + base[0] + base[1]) % block) % block
    return (base[0], base[1] + extra), (0, extra)


def run(model: tflite.Model, x: np.ndarray, size: Optional[Tuple[int, int]] = None,
        keep: bool = False, stop_at: Optional[int] = None):
    """Runs the graph on x (N x H x W x C, the graph's normalised input). size: the input (H, W) when
    it differs from the file's (x must have it). Returns the output array (and with keep, every
    tensor {index: array}). stop_at: stop after that operator index and return its first output."""
    inp = model.tensors[model.inputs[0]]
    file_hw = (inp.shape[1], inp.shape[2])
    smap = SizeMap(file_hw, size) if size and tuple(size) != file_hw else None
    if x.shape[1:3] != (size or file_hw):
        raise RefError(f"input is {x.shape[2]}x{x.shape[1]}, expected {(size or file_hw)[1]}x{(size or file_hw)[0]}")
    vals: Dict[int, np.ndarray] = {model.inputs[0]: x.astype(np.float32)}
    # Base paddings of each space-to-batch (its paddings minus the crops of the batch-to-space after it).
    crops_of = {}
    for op in model.operators:
        if op.opcode == "BATCH_TO_SPACE_ND":
            crops_of[op.inputs[0]] = model.tensors[op.inputs[2]].data
    producer = {o: op for op in model.operators for o in op.outputs}

    def const(t):
        v = model.tensors[t]
        if v.data is None:
            return vals[t]
        return tflite.dequantize(v)

    for op in model.operators:
        o = op.options
        ins = op.inputs
        get = lambda i: vals[ins[i]] if ins[i] in vals else const(ins[i])  # noqa: E731
        name = op.opcode
        if name == "DEQUANTIZE":
            y = const(ins[0])
        elif name == "CONV_2D":
            y = conv2d(get(0), get(1), get(2) if len(ins) > 2 and ins[2] >= 0 else 0.0,
                       (o["stride_h"], o["stride_w"]), (o["dilation_h"], o["dilation_w"]), o["padding"], o["activation"])
        elif name == "DEPTHWISE_CONV_2D":
            y = depthwise(get(0), get(1), get(2) if len(ins) > 2 and ins[2] >= 0 else 0.0,
                          (o["stride_h"], o["stride_w"]), (o["dilation_h"], o["dilation_w"]), o["padding"],
                          o["activation"], o["depth_multiplier"])
        elif name in ("ADD", "MUL"):
            a, b = get(0), get(1)
            y = _act(a + b if name == "ADD" else a * b, o["activation"]).astype(np.float32)
        elif name == "AVERAGE_POOL_2D":
            fh, fw = o["filter_h"], o["filter_w"]
            if smap:
                fh, fw = smap.dim(fh, 0), smap.dim(fw, 1)
            y = average_pool(get(0), fh, fw, (o["stride_h"], o["stride_w"]), o["padding"], o["activation"])
        elif name == "SPACE_TO_BATCH_ND":
            block = [int(v) for v in model.tensors[ins[1]].data]
            pads = [[int(a) for a in p] for p in model.tensors[ins[2]].data]
            if smap:
                # Find the batch-to-space this one pairs with (through the op after it) for its crops.
                crops = None
                for later in model.operators:
                    if later.opcode == "BATCH_TO_SPACE_ND" and later.inputs[0] in crops_of:
                        p = producer.get(later.inputs[0])
                        if p is not None and op.outputs[0] in p.inputs:
                            crops = crops_of[later.inputs[0]]
                if crops is None:
                    raise RefError(f"operator {op.index}: SPACE_TO_BATCH_ND without a BATCH_TO_SPACE_ND after it")
                xin = get(0)
                pads = [list(_s2b_pads(xin.shape[1 + a], block[a], (pads[a][0], pads[a][1] - int(crops[a][1])))[0])
                        for a in range(2)]
            y = space_to_batch(get(0), block, pads)
        elif name == "BATCH_TO_SPACE_ND":
            block = [int(v) for v in model.tensors[ins[1]].data]
            crops = [[int(a) for a in c] for c in model.tensors[ins[2]].data]
            if smap:
                # The crop is what the matching space-to-batch added beyond its base padding: recompute
                # from the size it must give back (the space-to-batch input's).
                s2b = producer[producer[ins[0]].inputs[0]]
                orig = vals[s2b.inputs[0]].shape
                xb = get(0)
                crops = [[0, xb.shape[1 + a] * block[a] - orig[1 + a]] for a in range(2)]
            y = batch_to_space(get(0), block, crops)
        elif name == "RESIZE_BILINEAR":
            oh, ow = [int(v) for v in model.tensors[ins[1]].data]
            if smap:
                oh, ow = smap.dim(oh, 0), smap.dim(ow, 1)
            y = resize_bilinear(get(0), oh, ow, o["align_corners"], o["half_pixel_centers"])
        elif name == "CONCATENATION":
            axis = o["axis"]
            y = _act(np.concatenate([get(i) for i in range(len(ins))], axis=axis), o["activation"])
        else:
            raise RefError(f"operator {op.index} ({name}) not supported by the reference, inputs "
                           + ", ".join(model.describe(t) for t in ins))
        vals[op.outputs[0]] = np.asarray(y, dtype=np.float32)
        if stop_at is not None and op.index == stop_at:
            return (vals[op.outputs[0]], vals) if keep else vals[op.outputs[0]]
    out = vals[model.outputs[0]]
    return (out, vals) if keep else out
