// Scalar reference layers. Written for clarity, not speed: each loop is the formula of
// docs/model_format.md, "Arithmetic", and the SIMD variants are tested against these bytes.
#include "nn/layers_ref.h"

#include <cstddef>

namespace ef::nn {

namespace {

inline std::size_t at(int w, int c, int y, int x) {
  return (static_cast<std::size_t>(y) * w + x) * c;
}

// The shared body of the three convolutions. `depthwise` selects the weight layout.
template <bool kDepthwise>
void conv_body(const ConvArgs& a) {
  const TensorI8& in = a.in;
  const MutTensorI8& out = a.out;
  const int32_t in_zp = in.zero_point;
  const std::size_t k_per_out = kDepthwise ? std::size_t(a.kernel_h) * a.kernel_w
                                           : std::size_t(a.kernel_h) * a.kernel_w * in.c;
  const int oy_end = a.oy_end < 0 ? out.h : a.oy_end;
  for (int oy = a.oy_begin; oy < oy_end; ++oy) {
    for (int ox = 0; ox < out.w; ++ox) {
      int8_t* dst = out.data + at(out.w, out.c, oy, ox);
      for (int oc = 0; oc < out.c; ++oc) {
        const int8_t* wrow = a.weights + oc * k_per_out;
        int32_t acc = a.bias[oc];  // |acc| < 2^31: the loader bounds bias and reduction length
        for (int ky = 0; ky < a.kernel_h; ++ky) {
          const int iy = oy * a.stride_h - a.pad_top + ky * a.dilation_h;
          if (iy < 0 || iy >= in.h) continue;
          for (int kx = 0; kx < a.kernel_w; ++kx) {
            const int ix = ox * a.stride_w - a.pad_left + kx * a.dilation_w;
            if (ix < 0 || ix >= in.w) continue;
            const int8_t* src = in.data + at(in.w, in.c, iy, ix);
            if (kDepthwise) {
              acc += (int32_t(src[oc]) - in_zp) * int32_t(wrow[ky * a.kernel_w + kx]);
            } else {
              const int8_t* wk = wrow + (std::size_t(ky) * a.kernel_w + kx) * in.c;
              for (int ic = 0; ic < in.c; ++ic) acc += (int32_t(src[ic]) - in_zp) * int32_t(wk[ic]);
            }
          }
        }
        dst[oc] = requantize(acc, a.requant[oc], out.zero_point, a.out_min, a.out_max);
      }
    }
  }
}

}  // namespace

void conv2d_i8_ref(const ConvArgs& a) { conv_body<false>(a); }
void dwconv2d_i8_ref(const ConvArgs& a) { conv_body<true>(a); }
void pwconv2d_i8_ref(const ConvArgs& a) { conv_body<false>(a); }  // 1x1: the general loop is the spec

void add_i8_ref(const AddArgs& a) {
  const std::size_t n = std::size_t(a.out.h) * a.out.w * a.out.c;
  const float y_lo = float(a.out_min - a.out.zero_point), y_hi = float(a.out_max - a.out.zero_point);
  for (std::size_t i = 0; i < n; ++i) {
    // Two float32 products and one float32 sum, in this order (docs/model_format.md 3.3).
    float y = float(int32_t(a.a.data[i]) - a.a.zero_point) * a.rq_a.multiplier +
              float(int32_t(a.b.data[i]) - a.b.zero_point) * a.rq_b.multiplier;
    y = y < y_lo ? y_lo : (y > y_hi ? y_hi : y);
    a.out.data[i] = static_cast<int8_t>(int32_t(round_half_even_small(y)) + a.out.zero_point);
  }
}

void concat_i8_ref(const ConcatArgs& a) {
  const std::size_t pixels = std::size_t(a.out.h) * a.out.w;
  for (std::size_t p = 0; p < pixels; ++p) {
    int8_t* dst = a.out.data + p * a.out.c;
    for (int k = 0; k < a.count; ++k) {
      const TensorI8& in = a.in[k];
      const int8_t* src = in.data + p * in.c;
      for (int c = 0; c < in.c; ++c) {
        dst[c] = requantize(int32_t(src[c]) - in.zero_point, a.rq[k], a.out.zero_point, -128, 127);
      }
      dst += in.c;
    }
  }
}

void clamp_i8_ref(const ClampArgs& a) {
  const std::size_t n = std::size_t(a.out.h) * a.out.w * a.out.c;
  for (std::size_t i = 0; i < n; ++i) {
    const int32_t v = a.in.data[i];
    a.out.data[i] = static_cast<int8_t>(v < a.out_min ? a.out_min : (v > a.out_max ? a.out_max : v));
  }
}

namespace {
// Calls f(iy, ix) for every input position of the pool window of output (oy, ox).
template <class F>
void for_window(const PoolArgs& a, int oy, int ox, F&& f) {
  for (int ky = 0; ky < a.kernel_h; ++ky) {
    const int iy = oy * a.stride_h - a.pad_top + ky;
    if (iy < 0 || iy >= a.in.h) continue;
    for (int kx = 0; kx < a.kernel_w; ++kx) {
      const int ix = ox * a.stride_w - a.pad_left + kx;
      if (ix < 0 || ix >= a.in.w) continue;
      f(iy, ix);
    }
  }
}
}  // namespace

void maxpool_i8_ref(const PoolArgs& a) {
  for (int oy = 0; oy < a.out.h; ++oy)
    for (int ox = 0; ox < a.out.w; ++ox)
      for (int c = 0; c < a.out.c; ++c) {
        int32_t m = -128;
        for_window(a, oy, ox, [&](int iy, int ix) {
          const int32_t v = a.in.data[at(a.in.w, a.in.c, iy, ix) + c];
          if (v > m) m = v;
        });
        a.out.data[at(a.out.w, a.out.c, oy, ox) + c] = static_cast<int8_t>(m);
      }
}

void avgpool_i8_ref(const PoolArgs& a) {
  for (int oy = 0; oy < a.out.h; ++oy)
    for (int ox = 0; ox < a.out.w; ++ox)
      for (int c = 0; c < a.out.c; ++c) {
        int32_t sum = 0;  // |sum| <= 255 * 256 * 256 < 2^31 (global pools up to 256 x 256)
        int count = 0;
        for_window(a, oy, ox, [&](int iy, int ix) {
          sum += int32_t(a.in.data[at(a.in.w, a.in.c, iy, ix) + c]) - a.in.zero_point;
          ++count;
        });
        // count >= 1: the loader keeps padding below the window size; count >= the table's base.
        const Requant rq = a.requant_by_count[count - a.requant_count_base];
        a.out.data[at(a.out.w, a.out.c, oy, ox) + c] = requantize(sum, rq, a.out.zero_point, -128, 127);
      }
}

void upsample_nearest_i8_ref(const UpsampleArgs& a) {
  for (int oy = 0; oy < a.out.h; ++oy)
    for (int ox = 0; ox < a.out.w; ++ox) {
      const int8_t* src = a.in.data + at(a.in.w, a.in.c, oy / a.factor, ox / a.factor);
      int8_t* dst = a.out.data + at(a.out.w, a.out.c, oy, ox);
      for (int c = 0; c < a.out.c; ++c) dst[c] = src[c];
    }
}

namespace {
// Half-pixel source position of output index o, in units of 1/(2f) input pixels:
// t = 2o + 1 - f, clamped at 0; i0 = t div 2f, r = t mod 2f, i1 = min(i0 + 1, n - 1).
struct Tap { int i0, i1, r; };
inline Tap bilinear_tap(int o, int f, int n) {
  int t = 2 * o + 1 - f;
  if (t < 0) t = 0;
  Tap tap;
  tap.i0 = t / (2 * f);
  tap.r = t - tap.i0 * 2 * f;
  tap.i1 = tap.i0 + 1 < n ? tap.i0 + 1 : n - 1;
  return tap;
}
}  // namespace

void upsample_bilinear_i8_ref(const UpsampleArgs& a) {
  const int f2 = 2 * a.factor;
  const int32_t denom = f2 * f2;  // weights sum to (2f)^2
  for (int oy = 0; oy < a.out.h; ++oy) {
    const Tap ty = bilinear_tap(oy, a.factor, a.in.h);
    for (int ox = 0; ox < a.out.w; ++ox) {
      const Tap tx = bilinear_tap(ox, a.factor, a.in.w);
      const int8_t* p00 = a.in.data + at(a.in.w, a.in.c, ty.i0, tx.i0);
      const int8_t* p01 = a.in.data + at(a.in.w, a.in.c, ty.i0, tx.i1);
      const int8_t* p10 = a.in.data + at(a.in.w, a.in.c, ty.i1, tx.i0);
      const int8_t* p11 = a.in.data + at(a.in.w, a.in.c, ty.i1, tx.i1);
      const int32_t w00 = (f2 - ty.r) * (f2 - tx.r), w01 = (f2 - ty.r) * tx.r;
      const int32_t w10 = ty.r * (f2 - tx.r), w11 = ty.r * tx.r;
      int8_t* dst = a.out.data + at(a.out.w, a.out.c, oy, ox);
      for (int c = 0; c < a.out.c; ++c) {
        // Interpolate u = q + 128 in [0, 255] so the division is of a non-negative number; round half up.
        const int32_t num = w00 * (p00[c] + 128) + w01 * (p01[c] + 128) + w10 * (p10[c] + 128) + w11 * (p11[c] + 128);
        dst[c] = static_cast<int8_t>((num + denom / 2) / denom - 128);
      }
    }
  }
}

void resize_bilinear_i8_ref(const ResizeArgs& a) {
  constexpr int32_t one = kResizeOne;
  for (int oy = 0; oy < a.out.h; ++oy) {
    const ResizeTap ty = resize_tap(oy, a.in.h, a.out.h);
    for (int ox = 0; ox < a.out.w; ++ox) {
      const ResizeTap tx = resize_tap(ox, a.in.w, a.out.w);
      const int8_t* p00 = a.in.data + at(a.in.w, a.in.c, ty.i0, tx.i0);
      const int8_t* p01 = a.in.data + at(a.in.w, a.in.c, ty.i0, tx.i1);
      const int8_t* p10 = a.in.data + at(a.in.w, a.in.c, ty.i1, tx.i0);
      const int8_t* p11 = a.in.data + at(a.in.w, a.in.c, ty.i1, tx.i1);
      int8_t* dst = a.out.data + at(a.out.w, a.out.c, oy, ox);
      for (int c = 0; c < a.out.c; ++c) {
        // u = q + 128 in [0, 255]: each row blend is below 2048 * 256 = 2^19, the whole sum at most
        // 2^22 * 255 < 2^31, so int32 is exact; round half up, then back to int8.
        const int32_t row0 = (one - tx.w) * (p00[c] + 128) + tx.w * (p01[c] + 128);
        const int32_t row1 = (one - tx.w) * (p10[c] + 128) + tx.w * (p11[c] + 128);
        const int32_t num = (one - ty.w) * row0 + ty.w * row1;
        dst[c] = static_cast<int8_t>(((num + (1 << (kResizeShift - 1))) >> kResizeShift) - 128);
      }
    }
  }
}

void softmax_i8_ref(const SoftmaxArgs& a) {
  const std::size_t pixels = std::size_t(a.in.h) * a.in.w;
  const int c = a.in.c;
  for (std::size_t p = 0; p < pixels; ++p) {
    const int8_t* q = a.in.data + p * c;
    float* out = a.out + p * c;
    int32_t qmax = -128;
    for (int k = 0; k < c; ++k) qmax = q[k] > qmax ? q[k] : qmax;
    float sum = 0.0f;  // float32, in channel order; >= 1 since exp_table[0] == 1
    for (int k = 0; k < c; ++k) sum += a.exp_table[qmax - q[k]];
    const float inv = 1.0f / sum;
    for (int k = 0; k < c; ++k) out[k] = a.exp_table[qmax - q[k]] * inv;
  }
}

}  // namespace ef::nn
