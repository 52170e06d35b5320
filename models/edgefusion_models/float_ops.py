"""float32 numpy kernels of the IR (graph.py): NHWC arrays, N free.

Written for calibration speed (one matrix product per kernel tap) and agreement with PyTorch
(within float32 rounding), not for bit-exactness with anything: the bit-exact path is int8_ref.py.
"""
import numpy as np


def _pad(x, pads, value=0.0):
    t, l, b, r = pads
    return np.pad(x, ((0, 0), (t, b), (l, r), (0, 0)), constant_values=value)


def _out_size(n, k, s, d, pa, pb):
    return (n + pa + pb - (d * (k - 1) + 1)) // s + 1


def _tap_slices(kh, kw, stride, dilation, oh, ow):
    for ky in range(kh):
        y0 = ky * dilation[0]
        for kx in range(kw):
            x0 = kx * dilation[1]
            yield ky, kx, (slice(None), slice(y0, y0 + (oh - 1) * stride[0] + 1, stride[0]),
                           slice(x0, x0 + (ow - 1) * stride[1] + 1, stride[1]), slice(None))


def conv2d(x, w, b, stride, dilation, pads):
    """w [Cout][kh][kw][Cin]; zero padding (the real value 0, the zero point in int8)."""
    n, h, wd, cin = x.shape
    cout, kh, kw, _ = w.shape
    oh = _out_size(h, kh, stride[0], dilation[0], pads[0], pads[2])
    ow = _out_size(wd, kw, stride[1], dilation[1], pads[1], pads[3])
    xp = _pad(x, pads)
    y = np.zeros((n * oh * ow, cout), dtype=np.float32)
    for ky, kx, sl in _tap_slices(kh, kw, stride, dilation, oh, ow):
        y += xp[sl].reshape(-1, cin) @ w[:, ky, kx, :].T
    return y.reshape(n, oh, ow, cout) + b


def depthwise_conv2d(x, w, b, stride, dilation, pads):
    """w [C][kh][kw], channel multiplier 1."""
    n, h, wd, c = x.shape
    _, kh, kw = w.shape
    oh = _out_size(h, kh, stride[0], dilation[0], pads[0], pads[2])
    ow = _out_size(wd, kw, stride[1], dilation[1], pads[1], pads[3])
    xp = _pad(x, pads)
    y = np.zeros((n, oh, ow, c), dtype=np.float32)
    for ky, kx, sl in _tap_slices(kh, kw, stride, dilation, oh, ow):
        y += xp[sl] * w[:, ky, kx]
    return y + b


def pointwise_conv2d(x, w, b):
    """w [Cout][Cin]."""
    n, h, wd, cin = x.shape
    return (x.reshape(-1, cin) @ w.T).reshape(n, h, wd, -1) + b


def _pool_taps(x, kernel, stride, pads, fill):
    n, h, w, c = x.shape
    oh = _out_size(h, kernel[0], stride[0], 1, pads[0], pads[2])
    ow = _out_size(w, kernel[1], stride[1], 1, pads[1], pads[3])
    xp = _pad(x, pads, fill)
    valid = _pad(np.ones((1, h, w, 1), dtype=np.float32), pads)
    for _, _, sl in _tap_slices(kernel[0], kernel[1], stride, (1, 1), oh, ow):
        yield xp[sl], valid[sl]


def max_pool(x, kernel, stride, pads):
    """Padding never wins (as -inf)."""
    out = None
    for v, _ in _pool_taps(x, kernel, stride, pads, -np.inf):
        out = v if out is None else np.maximum(out, v)
    return out


def avg_pool(x, kernel, stride, pads):
    """Mean over the window positions inside the input (count_include_pad=False)."""
    total, count = None, None
    for v, valid in _pool_taps(x, kernel, stride, pads, 0.0):
        total = v.copy() if total is None else total + v
        count = valid.copy() if count is None else count + valid
    return total / count


def upsample_nearest(x, f):
    return np.repeat(np.repeat(x, f, axis=1), f, axis=2)


def _linear_taps(n_in, f):
    """PyTorch align_corners=False: src = (o + 0.5) / f - 0.5 clamped at 0; weights of i0 and i1."""
    o = np.arange(n_in * f, dtype=np.float64)
    src = np.maximum((o + 0.5) / f - 0.5, 0.0)
    i0 = np.floor(src).astype(np.int64)
    i0 = np.minimum(i0, n_in - 1)
    lam = (src - i0).astype(np.float32)
    i1 = np.minimum(i0 + 1, n_in - 1)
    return i0, i1, lam


def upsample_bilinear(x, f):
    _, h, w, _ = x.shape
    i0, i1, ly = _linear_taps(h, f)
    rows = x[:, i0] * (1 - ly)[None, :, None, None] + x[:, i1] * ly[None, :, None, None]
    j0, j1, lx = _linear_taps(w, f)
    return rows[:, :, j0] * (1 - lx)[None, None, :, None] + rows[:, :, j1] * lx[None, None, :, None]


def _align_corners_taps(n_in, n_out):
    """TensorFlow ResizeBilinear with align_corners=True (half_pixel_centers=False): source position
    o * (n_in - 1) / (n_out - 1) (0 when n_out == 1); indices i0, i1 and the weight of i1."""
    o = np.arange(n_out, dtype=np.float64)
    src = o * (n_in - 1) / (n_out - 1) if n_out > 1 else np.zeros(n_out)
    i0 = np.minimum(np.floor(src).astype(np.int64), n_in - 1)
    i1 = np.minimum(i0 + 1, n_in - 1)
    return i0, i1, (src - i0).astype(np.float32)


def resize_bilinear(x, size):
    """Bilinear resize to size = (H, W), TensorFlow's align_corners rule (corners map to corners)."""
    _, h, w, _ = x.shape
    i0, i1, ly = _align_corners_taps(h, size[0])
    rows = x[:, i0] * (1 - ly)[None, :, None, None] + x[:, i1] * ly[None, :, None, None]
    j0, j1, lx = _align_corners_taps(w, size[1])
    return rows[:, :, j0] * (1 - lx)[None, None, :, None] + rows[:, :, j1] * lx[None, None, :, None]


def softmax(x):
    e = np.exp(x - x.max(axis=3, keepdims=True))
    return e / e.sum(axis=3, keepdims=True)
