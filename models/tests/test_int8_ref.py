"""int8_ref (vectorised numpy) against a slow, straightforward transcription of
docs/model_format.md section 3: one Python loop per output element, np.float32 scalars for every
float32 step, Python's round() (half to even) for the requantisation."""
import math
import unittest
from fractions import Fraction

import numpy as np

from edgefusion_models import int8_ref
from edgefusion_models.qmodel import DType, LayerType as T

from .helpers import random_input, resize_model, tiny_model


def f32(v):
    return np.float32(v)


def slow_requant(x, m, z, lo, hi):
    y = f32(x) * f32(m)                                    # binary32 product
    y = min(max(y, f32(lo - z)), f32(hi - z))
    return int(round(float(y))) + z                        # round half to even, exact for |y| <= 255


def slow_layer(model, l, vals):
    """One layer by the formulas of the doc, element by element."""
    ins = [vals[i] for i in l.inputs]
    tin = [model.tensors[i] for i in l.inputs]
    to = model.tensors[l.output]
    out = np.zeros((to.h, to.w, to.c), np.float32 if to.dtype == DType.FLOAT32 else np.int64)
    x, ti = ins[0], tin[0]
    if l.type in (T.CONV2D, T.DEPTHWISE_CONV2D, T.POINTWISE_CONV2D):
        kh, kw = l.kernel_h, l.kernel_w
        k = kh * kw * ti.c if l.type != T.DEPTHWISE_CONV2D else kh * kw
        for oy in range(to.h):
            for ox in range(to.w):
                for o in range(to.c):
                    acc = int(l.bias[o])
                    for ky in range(kh):
                        iy = oy * l.stride_h - l.pad_top + ky * l.dilation_h
                        for kx in range(kw):
                            ix = ox * l.stride_w - l.pad_left + kx * l.dilation_w
                            if not (0 <= iy < ti.h and 0 <= ix < ti.w):
                                continue
                            if l.type == T.DEPTHWISE_CONV2D:
                                acc += (int(x[iy, ix, o]) - ti.zero_point) * int(l.weights[o * k + ky * kw + kx])
                            else:
                                for c in range(ti.c):
                                    acc += ((int(x[iy, ix, c]) - ti.zero_point) *
                                            int(l.weights[o * k + (ky * kw + kx) * ti.c + c]))
                    m = f32(float(f32(ti.scale)) * float(f32(l.weight_scales[o])) / float(f32(to.scale)))
                    out[oy, ox, o] = slow_requant(acc, m, to.zero_point, l.out_min, l.out_max)
    elif l.type == T.ADD:
        a, b = ins
        ta, tb = tin
        ma = f32(float(f32(ta.scale)) / float(f32(to.scale)))
        mb = f32(float(f32(tb.scale)) / float(f32(to.scale)))
        for idx in np.ndindex(out.shape):
            y = f32(int(a[idx]) - ta.zero_point) * ma + f32(int(b[idx]) - tb.zero_point) * mb
            y = min(max(y, f32(l.out_min - to.zero_point)), f32(l.out_max - to.zero_point))
            out[idx] = int(round(float(y))) + to.zero_point
    elif l.type == T.CONCAT:
        c0 = 0
        for xi, t in zip(ins, tin):
            m = f32(float(f32(t.scale)) / float(f32(to.scale)))
            for idx in np.ndindex(xi.shape):
                out[idx[0], idx[1], c0 + idx[2]] = slow_requant(int(xi[idx]) - t.zero_point, m, to.zero_point, -128, 127)
            c0 += t.c
    elif l.type == T.CLAMP:
        for idx in np.ndindex(out.shape):
            out[idx] = min(max(int(x[idx]), l.out_min), l.out_max)
    elif l.type in (T.MAX_POOL, T.AVG_POOL):
        for oy in range(to.h):
            for ox in range(to.w):
                for c in range(to.c):
                    vals_in = [int(x[iy, ix, c])
                               for iy in (oy * l.stride_h - l.pad_top + ky for ky in range(l.kernel_h))
                               for ix in (ox * l.stride_w - l.pad_left + kx for kx in range(l.kernel_w))
                               if 0 <= iy < ti.h and 0 <= ix < ti.w]
                    if l.type == T.MAX_POOL:
                        out[oy, ox, c] = max(vals_in)
                    else:
                        n = len(vals_in)
                        m = f32((float(f32(ti.scale)) / float(f32(to.scale))) / n)
                        out[oy, ox, c] = slow_requant(sum(v - ti.zero_point for v in vals_in), m, to.zero_point, -128, 127)
    elif l.type == T.UPSAMPLE:
        f = l.factor
        for oy in range(to.h):
            for ox in range(to.w):
                if l.mode == 0:
                    out[oy, ox] = x[oy // f, ox // f]
                    continue
                # (o + 0.5) / f - 0.5 in units of 1 / (2f), clamped at 0.
                def tap(o, n):
                    t = max(2 * o + 1 - f, 0)
                    i0 = t // (2 * f)
                    return i0, min(i0 + 1, n - 1), t - i0 * 2 * f
                y0, y1, ry = tap(oy, ti.h)
                x0, x1, rx = tap(ox, ti.w)
                F, D = 2 * f, 4 * f * f
                for c in range(to.c):
                    u = lambda yy, xx: int(x[yy, xx, c]) + 128
                    num = ((F - ry) * (F - rx) * u(y0, x0) + (F - ry) * rx * u(y0, x1) + ry * (F - rx) * u(y1, x0) +
                           ry * rx * u(y1, x1))
                    out[oy, ox, c] = (num + D // 2) // D - 128
    elif l.type == T.RESIZE_BILINEAR:
        # 3.9: TensorFlow align_corners taps in units of 1/2048, u = q + 128, round half up at 2^22.
        def rtap(o, n, m):
            if m == 1 or n == 1:
                return 0, 0, 0
            num, den = o * (n - 1), m - 1
            return num // den, min(num // den + 1, n - 1), ((num % den) * 2048 + den // 2) // den
        for oy in range(to.h):
            y0, y1, wy = rtap(oy, ti.h, to.h)
            for ox in range(to.w):
                x0, x1, wx = rtap(ox, ti.w, to.w)
                for c in range(to.c):
                    u = lambda yy, xx: int(x[yy, xx, c]) + 128
                    num = ((2048 - wy) * ((2048 - wx) * u(y0, x0) + wx * u(y0, x1)) +
                           wy * ((2048 - wx) * u(y1, x0) + wx * u(y1, x1)))
                    assert num < 2 ** 31
                    out[oy, ox, c] = ((num + (1 << 21)) >> 22) - 128
    elif l.type == T.SOFTMAX:
        table = [f32(math.exp(-float(f32(ti.scale)) * d)) for d in range(256)]
        for oy in range(to.h):
            for ox in range(to.w):
                q = [int(v) for v in x[oy, ox]]
                qmax = max(q)
                s = f32(0)
                for v in q:
                    s = f32(s + table[qmax - v])
                inv = f32(1) / s
                for c, v in enumerate(q):
                    out[oy, ox, c] = table[qmax - v] * inv
    else:
        raise AssertionError(l.type)
    return out if to.dtype == DType.FLOAT32 else out.astype(np.int8)


class Int8RefTest(unittest.TestCase):
    def test_every_layer_matches_the_slow_reference(self):
        for seed in (1, 2):
            model = tiny_model(seed)
            x = random_input(model, seed)
            probs, tensors = int8_ref.run(model, x, keep_tensors=True)
            vals = {model.input_tensor: x}
            for li, l in enumerate(model.layers):
                want = slow_layer(model, l, vals)
                vals[l.output] = want
                got = probs if l.type == T.SOFTMAX else tensors[l.output]
                self.assertEqual(got.dtype, want.dtype)
                np.testing.assert_array_equal(got.view(np.uint8 if got.dtype == np.int8 else np.uint32),
                                              want.view(np.uint8 if want.dtype == np.int8 else np.uint32),
                                              err_msg=f"seed {seed}, layer {li} ({l.type.name})")
            # Not degenerate: the logits spread over many values.
            self.assertGreater(len(np.unique(tensors[11])), 20)

    def test_resize_and_global_pool_match_the_slow_reference(self):
        model = resize_model()
        for seed in (0, 1):
            x = random_input(model, seed)
            if seed == 1:
                x[:] = np.where(np.arange(x.size).reshape(x.shape) % 3 == 0, 127, -128)  # extreme blends
            probs, tensors = int8_ref.run(model, x, keep_tensors=True)
            vals = {model.input_tensor: x}
            for li, l in enumerate(model.layers):
                want = slow_layer(model, l, vals)
                vals[l.output] = want
                got = probs if l.type == T.SOFTMAX else tensors[l.output]
                np.testing.assert_array_equal(got.view(np.uint8 if got.dtype == np.int8 else np.uint32),
                                              want.view(np.uint8 if want.dtype == np.int8 else np.uint32),
                                              err_msg=f"seed {seed}, layer {li} ({l.type.name})")

    def test_resize_by_hand(self):
        # 2x2 -> 3x3, u = [[0, 255], [128, 178]]: midpoints 127.5 -> 128, 216.5 -> 217 (half up), centre
        # 140.25 -> 140, corners copied (the C++ twin: ResizeBilinearRule.HandComputed2x2To3x3).
        from edgefusion_models.qmodel import QTensor
        x = np.int8([[-128, 127], [0, 50]]).reshape(2, 2, 1)
        y = int8_ref.resize_bilinear(x, QTensor(h=3, w=3, c=1))
        np.testing.assert_array_equal(y[:, :, 0], [[-128, 0, 127], [-64, 12, 89], [0, 25, 50]])
        # 1x1 -> 4x5 is a broadcast; n -> 1 takes the first pixel.
        x = np.int8([[[5, -7, 127]]])
        np.testing.assert_array_equal(int8_ref.resize_bilinear(x, QTensor(h=4, w=5, c=3)), np.broadcast_to(x, (4, 5, 3)))
        x = np.arange(-20, 40, dtype=np.int8).reshape(3, 4, 5)
        np.testing.assert_array_equal(int8_ref.resize_bilinear(x, QTensor(h=1, w=1, c=5)), x[:1, :1])

    def test_requantize_rounds_half_to_even_after_clamping(self):
        q = int8_ref.requantize(np.array([5, 7, -5, -7, 1000, -1000, 3]), np.float32(0.5), 1, -128, 127)
        # 2.5 -> 2, 3.5 -> 4, -2.5 -> -2, -3.5 -> -4, clamps at 127 - 1 and -128 - 1, 1.5 -> 2; plus zp 1.
        np.testing.assert_array_equal(q, [3, 5, -1, -3, 127, -128, 3])
        q = int8_ref.requantize(np.array([100]), np.float32(1.0), -128, -128, -100)  # ReLU6-like upper bound
        np.testing.assert_array_equal(q, [-100])

    def test_input_quantisation_is_std_round(self):
        model = tiny_model()
        t = model.tensors[0]
        model.input_mean = [0.0] * 4
        model.input_scale = [float(np.float32(t.scale))] * 4  # t = v exactly
        z = t.zero_point
        v = np.array([2.5, -2.5, 0.5 - 2.0 ** -54, 1000.0, -1000.0, np.nan, 0.49999997, 3.0], np.float64)
        # float32 input: 0.5 - 2^-54 is not a float32 (it becomes 0.5); use exact float32 values.
        raw = np.zeros((6, 8, 4), np.float32)
        raw.reshape(-1)[:8] = v.astype(np.float32)
        q = int8_ref.quantize_input(raw, model).reshape(-1)[:8]
        np.testing.assert_array_equal(q, np.array([3, -3, 1, 127, -128, 0, 0, 3]) + np.array([z, z, z, 0, 0, z, z, z]))
        # Random raw frames against an exact rational transcription of 3.1.
        rs = np.random.RandomState(4)
        raw = (rs.uniform(-20, 300, size=(6, 8, 4)) * np.float32([1, 1, 1, 0.05])).astype(np.float32)
        raw.reshape(-1)[::7] = np.round(raw.reshape(-1)[::7])  # integers: exact ties with mean 128 + k/2
        model = tiny_model()
        model.input_mean = [127.5, 128.0, 100.25, 2.0]
        model.input_scale = [1 / 64, 1 / 127.5, 0.02, 1.0 / 3.0]
        t_in = model.tensors[0]
        q = int8_ref.quantize_input(raw, model)
        for idx in np.ndindex(raw.shape):
            c = idx[2]
            # double arithmetic exactly as 3.1 (each step rounded to double), then an exact std::round.
            mul = float(np.float32(model.input_scale[c])) / float(np.float32(t_in.scale))
            tv = (float(raw[idx]) - float(np.float32(model.input_mean[c]))) * mul
            fr = Fraction(tv)
            r = math.floor(abs(fr) + Fraction(1, 2)) * (1 if fr >= 0 else -1)
            self.assertEqual(int(q[idx]), min(127, max(-128, t_in.zero_point + r)), idx)
        # The doc's caveat: sign * floor(|t| + 0.5) rounds 0.5 - 2^-54 up; std::round does not.
        self.assertEqual(int8_ref.round_half_away(np.array([0.5 - 2.0 ** -54]))[0], 0.0)
        self.assertEqual(int8_ref.round_half_away(np.array([-0.5, 0.5, 1.5, -1.5]))[0:4].tolist(), [-1, 1, 2, -2])


if __name__ == "__main__":
    unittest.main()
