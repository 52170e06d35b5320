"""Integer forward pass of a quantised model, bit for bit the C++ runtime (docs/model_format.md 3).

Tensors are HWC numpy arrays (N = 1). Every float step is an IEEE binary32 numpy operation on
np.float32 arrays (numpy never fuses a multiply and an add), every rounding the one of the doc:
np.rint for the requantisation (round half to even), exact integer "round half up" for bilinear
upsampling and resizing, std::round semantics for the input quantisation.

Convolution accumulators are computed with float64 matrix products: every product and partial sum
is an integer below 2^31 (|q - z| <= 255, |w| <= 127, K <= 32768), hence exact in float64 whatever
order or FMA the BLAS uses, and much faster than numpy's integer matmul.
"""
import math

import numpy as np

from .qmodel import (DType, LayerType, QModel, avg_real_multiplier, conv_real_multiplier, make_multiplier,
                     ratio_real_multiplier, resize_tap)


def requantize(x, m, zp, lo, hi):
    """3.0: q = round_half_even(clamp(float32(x) * m, lo - zp, hi - zp)) + zp, as int8.

    x: integer array (int32 range); m: np.float32 scalar or array broadcasting against x."""
    y = np.asarray(x, dtype=np.int64).astype(np.int32).astype(np.float32) * np.asarray(m, dtype=np.float32)
    y = np.clip(y, np.float32(lo - zp), np.float32(hi - zp))
    return (np.rint(y).astype(np.int32) + zp).astype(np.int8)


def round_half_away(t):
    """C's std::round on float64 values, exactly (trunc and the fraction are exact in binary64)."""
    r = np.trunc(t)
    frac = t - r
    return r + np.where(np.abs(frac) >= 0.5, np.sign(t), 0.0)


def quantize_input(raw, model: QModel):
    """3.1: raw H x W x C values (R, G, B 0..255, depth metres) -> the int8 input tensor."""
    t_in = model.tensors[model.input_tensor]
    raw = np.asarray(raw, dtype=np.float32).astype(np.float64)
    mean = np.array([float(np.float32(v)) for v in model.input_mean])
    mul = np.array([float(np.float32(v)) / float(np.float32(t_in.scale)) for v in model.input_scale])
    t = (raw - mean) * mul
    nan = np.isnan(t)
    q = np.where(nan, 0.0, round_half_away(np.where(nan, 0.0, t))) + t_in.zero_point
    return np.clip(q, -128, 127).astype(np.int8)


def _padded_centered(x, zp, l):
    """x - zp as int32 with the layer's zero padding (padding contributes nothing: 3.2)."""
    xc = x.astype(np.int32) - zp
    return np.pad(xc, ((l.pad_top, l.pad_bottom), (l.pad_left, l.pad_right), (0, 0)))


def _taps(l, oh, ow):
    """(ky, kx, row slice, column slice) of each kernel tap into the padded input."""
    for ky in range(l.kernel_h):
        y0 = ky * l.dilation_h
        for kx in range(l.kernel_w):
            x0 = kx * l.dilation_w
            yield ky, kx, slice(y0, y0 + (oh - 1) * l.stride_h + 1, l.stride_h), \
                slice(x0, x0 + (ow - 1) * l.stride_w + 1, l.stride_w)


def conv(l, x, t_in, t_out):
    """conv2d, depthwise and pointwise (3.2)."""
    xp = _padded_centered(x, t_in.zero_point, l)
    oh, ow, cout = t_out.h, t_out.w, t_out.c
    if l.type == LayerType.DEPTHWISE_CONV2D:
        w = l.weights.reshape(cout, l.kernel_h, l.kernel_w).astype(np.int32)
        acc = np.zeros((oh, ow, cout), dtype=np.int32)
        for ky, kx, ys, xs in _taps(l, oh, ow):
            acc += xp[ys, xs, :] * w[:, ky, kx]
    else:
        cin = t_in.c
        w = l.weights.reshape(cout, l.kernel_h, l.kernel_w, cin).astype(np.float64)
        accf = np.zeros((oh * ow, cout), dtype=np.float64)
        for ky, kx, ys, xs in _taps(l, oh, ow):
            accf += xp[ys, xs, :].reshape(-1, cin).astype(np.float64) @ w[:, ky, kx, :].T
        acc = accf.reshape(oh, ow, cout).astype(np.int64)
    acc = acc.astype(np.int64) + l.bias.astype(np.int64)
    assert np.all(np.abs(acc) < 2 ** 31), "accumulator overflow (the loader's limits make this impossible)"
    m = np.array([make_multiplier(conv_real_multiplier(t_in.scale, ws, t_out.scale)) for ws in l.weight_scales],
                 dtype=np.float32)
    return requantize(acc, m, t_out.zero_point, l.out_min, l.out_max)


def add(l, a, b, ta, tb, t_out):
    """3.3: two float32 products and one float32 sum, then the clamp and rounding of 3.0."""
    ma = make_multiplier(ratio_real_multiplier(ta.scale, t_out.scale))
    mb = make_multiplier(ratio_real_multiplier(tb.scale, t_out.scale))
    ya = (a.astype(np.int32) - ta.zero_point).astype(np.float32) * ma
    yb = (b.astype(np.int32) - tb.zero_point).astype(np.float32) * mb
    y = np.clip(ya + yb, np.float32(l.out_min - t_out.zero_point), np.float32(l.out_max - t_out.zero_point))
    return (np.rint(y).astype(np.int32) + t_out.zero_point).astype(np.int8)


def concat(xs, ts, t_out):
    """3.4: each input requantised into the output's quantisation (an exact copy when they match)."""
    parts = []
    for x, t in zip(xs, ts):
        m = make_multiplier(ratio_real_multiplier(t.scale, t_out.scale))
        parts.append(requantize(x.astype(np.int32) - t.zero_point, m, t_out.zero_point, -128, 127))
    return np.concatenate(parts, axis=2)


def clamp(l, x):
    return np.clip(x, l.out_min, l.out_max).astype(np.int8)


def _pool_windows(l, x, oh, ow, fill):
    """Yields each window tap of every output as an (oh, ow, c) array plus its validity mask."""
    h, w, _ = x.shape
    xp = np.pad(x, ((l.pad_top, l.pad_bottom), (l.pad_left, l.pad_right), (0, 0)), constant_values=fill)
    valid = np.pad(np.ones((h, w), dtype=np.int32), ((l.pad_top, l.pad_bottom), (l.pad_left, l.pad_right)))
    for ky in range(l.kernel_h):
        ys = slice(ky, ky + (oh - 1) * l.stride_h + 1, l.stride_h)
        for kx in range(l.kernel_w):
            xs = slice(kx, kx + (ow - 1) * l.stride_w + 1, l.stride_w)
            yield xp[ys, xs, :], valid[ys, xs]


def max_pool(l, x, t_out):
    """3.5: the maximum over window positions inside the input (padding never wins)."""
    out = np.full((t_out.h, t_out.w, t_out.c), -128, dtype=np.int32)
    for v, _ in _pool_windows(l, x.astype(np.int32), t_out.h, t_out.w, -128):
        out = np.maximum(out, v)
    return out.astype(np.int8)


def avg_pool(l, x, t_in, t_out):
    """3.6: the sum over positions inside the input, requantised by the multiplier of its count."""
    total = np.zeros((t_out.h, t_out.w, t_out.c), dtype=np.int32)
    count = np.zeros((t_out.h, t_out.w), dtype=np.int32)
    for v, valid in _pool_windows(l, x.astype(np.int32) - t_in.zero_point, t_out.h, t_out.w, 0):
        total += v
        count += valid
    # The multiplier of each count that occurs (a global pool: the one count kh*kw, up to 65536).
    counts = np.unique(count)
    table = {int(n): make_multiplier(avg_real_multiplier(t_in.scale, t_out.scale, int(n))) for n in counts}
    m = np.zeros(count.shape, dtype=np.float32)
    for n, mult in table.items():
        m[count == n] = mult
    return requantize(total, m[:, :, None], t_out.zero_point, -128, 127)


def bilinear_taps(n_out, f, n_in):
    """3.7 along one axis: (i0, i1, r) per output index, r in units of 1/(2f) pixel."""
    o = np.arange(n_out, dtype=np.int64)
    t = np.maximum(2 * o + 1 - f, 0)
    i0 = t // (2 * f)
    r = t - i0 * 2 * f
    i1 = np.minimum(i0 + 1, n_in - 1)
    return i0, i1, r


def upsample(l, x):
    f = l.factor
    h, w, _ = x.shape
    if l.mode == 0:  # nearest: out(y, x) = in(y / f, x / f)
        return np.repeat(np.repeat(x, f, axis=0), f, axis=1)
    F, D = 2 * f, 4 * f * f
    u = x.astype(np.int64) + 128  # non-negative, so // is the exact floor division of 3.7
    i0y, i1y, ry = bilinear_taps(h * f, f, h)
    i0x, i1x, rx = bilinear_taps(w * f, f, w)
    # (F-ry)(F-rx)u00 + (F-ry)rx u01 + ry(F-rx)u10 + ry rx u11, grouped by rows first: integers, exact.
    rows = (F - ry)[:, None, None] * u[i0y] + ry[:, None, None] * u[i1y]
    num = (F - rx)[None, :, None] * rows[:, i0x] + rx[None, :, None] * rows[:, i1x]
    return ((num + D // 2) // D - 128).astype(np.int8)


def resize_taps(n_in, n_out):
    """3.9 along one axis: (i0, i1, w) arrays, w the weight of i1 in units of 1/2048."""
    taps = np.array([resize_tap(o, n_in, n_out) for o in range(n_out)], dtype=np.int64).reshape(n_out, 3)
    return taps[:, 0], taps[:, 1], taps[:, 2]


def resize_bilinear(x, t_out):
    """3.9: bilinear resize to t_out's H x W, TensorFlow align_corners, 11-bit weights; u = q + 128,
    num = (2048 - wy)((2048 - wx) u00 + wx u01) + wy((2048 - wx) u10 + wx u11) in int64 (exact, below
    2^31), q = ((num + 2^21) >> 22) - 128."""
    h, w, _ = x.shape
    u = x.astype(np.int64) + 128
    i0y, i1y, wy = resize_taps(h, t_out.h)
    i0x, i1x, wx = resize_taps(w, t_out.w)
    # Columns first (each row of u blended along x), then rows: the same integers as the doc's grouping.
    cols = (2048 - wx)[None, :, None] * u[:, i0x] + wx[None, :, None] * u[:, i1x]
    num = (2048 - wy)[:, None, None] * cols[i0y] + wy[:, None, None] * cols[i1y]
    return (((num + (1 << 21)) >> 22) - 128).astype(np.int8)


def softmax_table(scale):
    """3.8: table[d] = float32(exp(-double(s) * d)); math.exp is the C library's exp, as std::exp."""
    s = float(np.float32(scale))
    return np.array([math.exp(-s * d) for d in range(256)], dtype=np.float64).astype(np.float32)


def softmax(x, t_in):
    table = softmax_table(t_in.scale)
    q = x.astype(np.int32)
    e = table[q.max(axis=2, keepdims=True) - q]  # float32
    total = np.zeros(q.shape[:2], dtype=np.float32)
    for c in range(q.shape[2]):  # float32 sum in channel order
        total = total + e[:, :, c]
    inv = np.float32(1.0) / total
    return e * inv[:, :, None]


def run(model: QModel, input_q, keep_tensors=False):
    """Runs the layers on an int8 input tensor (H x W x C); returns (probabilities float32 H'xW'xK,
    {tensor id: array} of every int8 tensor when keep_tensors else {})."""
    t_in = model.tensors[model.input_tensor]
    x = np.asarray(input_q, dtype=np.int8).reshape(t_in.h, t_in.w, t_in.c)
    vals = {model.input_tensor: x}
    probs = None
    for l in model.layers:
        ins = [vals[i] for i in l.inputs]
        tins = [model.tensors[i] for i in l.inputs]
        tout = model.tensors[l.output]
        if l.type in (LayerType.CONV2D, LayerType.DEPTHWISE_CONV2D, LayerType.POINTWISE_CONV2D):
            y = conv(l, ins[0], tins[0], tout)
        elif l.type == LayerType.ADD:
            y = add(l, ins[0], ins[1], tins[0], tins[1], tout)
        elif l.type == LayerType.CONCAT:
            y = concat(ins, tins, tout)
        elif l.type == LayerType.CLAMP:
            y = clamp(l, ins[0])
        elif l.type == LayerType.MAX_POOL:
            y = max_pool(l, ins[0], tout)
        elif l.type == LayerType.AVG_POOL:
            y = avg_pool(l, ins[0], tins[0], tout)
        elif l.type == LayerType.UPSAMPLE:
            y = upsample(l, ins[0])
        elif l.type == LayerType.RESIZE_BILINEAR:
            y = resize_bilinear(ins[0], tout)
        elif l.type == LayerType.SOFTMAX:
            y = softmax(ins[0], tins[0])
        else:
            raise ValueError(f"unknown layer type {l.type}")
        if tout.dtype == DType.FLOAT32:
            probs = y
        vals[l.output] = y
    if not keep_tensors:
        vals = {}
    else:
        vals = {k: v for k, v in vals.items() if model.tensors[k].dtype == DType.INT8}
    return probs, vals
