// The shared requantisation and every scalar reference op, against a straightforward float
// computation (dequantise -> double op -> requantise with round-to-nearest): within 1 LSB where the
// float32 arithmetic or the half-even rounding may differ from it, exactly where the spec says so.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "nn/layers_ref.h"
#include "nn/requantize.h"

namespace ef::nn {
namespace {

Requant rq_of(double m) {
  Requant r;
  EXPECT_TRUE(make_multiplier(m, &r.multiplier)) << m;
  return r;
}
int8_t quantize_ref(double real, double scale, int zp, int lo = -128, int hi = 127) {
  const double q = std::nearbyint(real / scale) + zp;  // half to even, as the runtime
  return static_cast<int8_t>(std::clamp(q, double(lo), double(hi)));
}

TEST(NnRequant, Multipliers) {
  float m = 0;
  // Rounded once from double to float32.
  ASSERT_TRUE(make_multiplier(0.1, &m));
  EXPECT_EQ(m, 0.1f);
  ASSERT_TRUE(make_multiplier(1.0, &m));
  EXPECT_EQ(m, 1.0f);
  // Accepted range: normal floats below 2^24.
  EXPECT_TRUE(make_multiplier(double(FLT_MIN), &m));
  EXPECT_TRUE(make_multiplier(std::nextafter(16777216.0, 0.0) - 1.0, &m));
  for (double bad : {0.0, -1.0, 1e-45 /* subnormal as float */, 1e-39, 16777216.0, 1e30, std::nan(""), double(INFINITY)})
    EXPECT_FALSE(make_multiplier(bad, &m)) << bad;
}

TEST(NnRequant, RoundingHalfEvenAndSaturation) {
  const Requant half = rq_of(0.5);
  // Half-way cases round to even: 0.5 -> 0, -0.5 -> 0, 1.5 -> 2, -1.5 -> -2, 2.5 -> 2.
  EXPECT_EQ(requantize(1, half, 0, -128, 127), 0);
  EXPECT_EQ(requantize(-1, half, 0, -128, 127), 0);
  EXPECT_EQ(requantize(3, half, 0, -128, 127), 2);
  EXPECT_EQ(requantize(-3, half, 0, -128, 127), -2);
  EXPECT_EQ(requantize(5, half, 0, -128, 127), 2);
  EXPECT_EQ(requantize(5, half, 7, -128, 127), 9);  // the zero point is added after rounding
  const Requant one = rq_of(1.0);
  EXPECT_EQ(requantize(127, one, 0, -128, 127), 127);
  EXPECT_EQ(requantize(128, one, 0, -128, 127), 127);
  EXPECT_EQ(requantize(-129, one, 0, -128, 127), -128);
  EXPECT_EQ(requantize(100, one, 30, -128, 127), 127);  // zero point pushes past the top
  EXPECT_EQ(requantize(-100, one, -30, -128, 127), -128);
  // Accumulator extremes with the largest multiplier: clamped in float before the conversion.
  const Requant huge = rq_of(16777215.0);
  EXPECT_EQ(requantize(INT32_MAX, huge, 0, -128, 127), 127);
  EXPECT_EQ(requantize(INT32_MIN, huge, 0, -128, 127), -128);
  EXPECT_EQ(requantize(INT32_MIN, huge, -128, -128, 127), -128);
  EXPECT_EQ(requantize(INT32_MAX, huge, 127, -128, 127), 127);
  EXPECT_EQ(requantize(INT32_MIN, rq_of(1e-30), 5, -128, 127), 5);
  // float(acc) rounds above 2^24 (to even): 2^24 + 1 -> 2^24, then * 2^-24 = 1.
  EXPECT_EQ(requantize((1 << 24) + 1, rq_of(std::ldexp(1.0, -24)), 0, -128, 127), 1);
  EXPECT_EQ(requantize((1 << 24) + 3 * (1 << 23), rq_of(std::ldexp(1.0, -24)), 0, -128, 127), 2);  // 2.5 -> 2
  // Fused activation range.
  EXPECT_EQ(requantize(-50, one, 0, 0, 127), 0);
  EXPECT_EQ(requantize(90, one, 0, 0, 85), 85);
  // The scalar rounding helper agrees with nearbyint over the whole clamped range, in quarter steps.
  for (int i = -4 * 256; i <= 4 * 256; ++i) {
    const float y = float(i) / 4;
    EXPECT_EQ(round_half_even_small(y), std::nearbyint(y)) << y;
  }
}

struct Q {
  std::vector<int8_t> q;
  int h, w, c;
  float scale;
  int zp;
  double real(size_t i) const { return double(scale) * (q[i] - zp); }
  TensorI8 view() const { return {q.data(), h, w, c, zp}; }
};
Q random_q(int h, int w, int c, float scale, int zp, std::mt19937& rng) {
  Q t{std::vector<int8_t>(size_t(h) * w * c), h, w, c, scale, zp};
  std::uniform_int_distribution<int> d(-128, 127);
  for (auto& v : t.q) v = static_cast<int8_t>(d(rng));
  return t;
}

// Counts outputs and how many differ from the float reference by exactly 1 (none by more).
void compare_lsb(const std::vector<int8_t>& got, const std::vector<int8_t>& want, const char* what) {
  ASSERT_EQ(got.size(), want.size());
  size_t off_by_one = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    const int d = std::abs(int(got[i]) - int(want[i]));
    ASSERT_LE(d, 1) << what << " element " << i;
    off_by_one += d;
  }
  // Off-by-one happens only at exact .5 ties (half even vs. the reference's half away) and where the
  // float32 rounding of the multiplier or product moves a value across one.
  EXPECT_LE(off_by_one, got.size() / 50 + 1) << what;
}

struct ConvCase { int h, w, cin, cout, k, stride, dil, pad; bool depthwise; };

void run_conv_case(const ConvCase& cc, std::mt19937& rng) {
  const int oh = (cc.h + 2 * cc.pad - cc.dil * (cc.k - 1) - 1) / cc.stride + 1;
  const int ow = (cc.w + 2 * cc.pad - cc.dil * (cc.k - 1) - 1) / cc.stride + 1;
  const int cout = cc.depthwise ? cc.cin : cc.cout;
  Q in = random_q(cc.h, cc.w, cc.cin, 0.03f, -7, rng);
  const float out_scale = 0.25f;
  const int out_zp = 4;
  const int per = cc.depthwise ? cc.k * cc.k : cc.k * cc.k * cc.cin;
  std::vector<int8_t> w(size_t(cout) * per);
  std::vector<float> ws(cout);
  std::vector<int32_t> bias(cout);
  std::vector<Requant> rq(cout);
  std::uniform_int_distribution<int> wd(-127, 127), bd(-3000, 3000);
  std::uniform_real_distribution<float> sd(0.001f, 0.01f);
  for (auto& v : w) v = static_cast<int8_t>(wd(rng));
  for (int c = 0; c < cout; ++c) {
    ws[c] = sd(rng);
    bias[c] = bd(rng);
    rq[c] = rq_of(double(in.scale) * ws[c] / out_scale);
  }
  std::vector<int8_t> got(size_t(oh) * ow * cout);
  ConvArgs a;
  a.in = in.view();
  a.out = {got.data(), oh, ow, cout, out_zp};
  a.kernel_h = a.kernel_w = cc.k;
  a.stride_h = a.stride_w = cc.stride;
  a.dilation_h = a.dilation_w = cc.dil;
  a.pad_top = a.pad_left = cc.pad;
  a.weights = w.data(); a.bias = bias.data(); a.requant = rq.data();
  a.out_min = out_zp;  // ReLU folded in
  (cc.depthwise ? dwconv2d_i8_ref : (cc.k == 1 && cc.stride == 1 && cc.pad == 0 ? pwconv2d_i8_ref : conv2d_i8_ref))(a);

  std::vector<int8_t> want(got.size());
  for (int oy = 0; oy < oh; ++oy)
    for (int ox = 0; ox < ow; ++ox)
      for (int oc = 0; oc < cout; ++oc) {
        double acc = double(bias[oc]) * in.scale * ws[oc];
        for (int ky = 0; ky < cc.k; ++ky)
          for (int kx = 0; kx < cc.k; ++kx) {
            const int iy = oy * cc.stride - cc.pad + ky * cc.dil, ix = ox * cc.stride - cc.pad + kx * cc.dil;
            if (iy < 0 || ix < 0 || iy >= cc.h || ix >= cc.w) continue;  // zero padding (real 0)
            if (cc.depthwise) {
              acc += in.real((size_t(iy) * cc.w + ix) * cc.cin + oc) * ws[oc] * w[size_t(oc) * per + ky * cc.k + kx];
            } else {
              for (int ic = 0; ic < cc.cin; ++ic)
                acc += in.real((size_t(iy) * cc.w + ix) * cc.cin + ic) * ws[oc] *
                       w[size_t(oc) * per + (size_t(ky) * cc.k + kx) * cc.cin + ic];
            }
          }
        want[(size_t(oy) * ow + ox) * cout + oc] = quantize_ref(std::max(acc, 0.0), out_scale, out_zp);
      }
  compare_lsb(got, want, "conv");
}

TEST(NnLayers, ConvolutionsAgainstFloat) {
  std::mt19937 rng(11);
  const ConvCase cases[] = {
      {9, 7, 5, 6, 3, 1, 1, 1, false},  {9, 8, 4, 3, 3, 2, 1, 1, false}, {10, 9, 3, 4, 3, 1, 2, 2, false},
      {7, 7, 3, 5, 5, 2, 1, 2, false},  {6, 5, 16, 7, 1, 1, 1, 0, false}, {9, 9, 6, 6, 3, 1, 1, 1, true},
      {9, 10, 5, 5, 3, 2, 1, 1, true},  {11, 11, 4, 4, 3, 1, 3, 3, true},
  };
  for (const auto& cc : cases) run_conv_case(cc, rng);
}

TEST(NnLayers, AddAgainstFloat) {
  std::mt19937 rng(5);
  Q a = random_q(5, 6, 7, 0.05f, 3, rng), b = random_q(5, 6, 7, 0.02f, -9, rng);
  const float os = 0.06f;
  const int ozp = -2;
  std::vector<int8_t> got(a.q.size());
  AddArgs args;
  args.a = a.view(); args.b = b.view();
  args.out = {got.data(), 5, 6, 7, ozp};
  args.rq_a = rq_of(double(a.scale) / os); args.rq_b = rq_of(double(b.scale) / os);
  add_i8_ref(args);
  // Exact, except within 1e-4 of a rounding tie, where float32 and double may fall either side
  // (these scales put a sixth of all sums on a tie).
  for (size_t i = 0; i < got.size(); ++i) {
    const double v = (a.real(i) + b.real(i)) / os;
    const bool near_tie = std::abs(std::abs(v - std::floor(v)) - 0.5) < 1e-4;
    const int w = quantize_ref(a.real(i) + b.real(i), os, ozp);
    if (near_tie) {
      EXPECT_LE(std::abs(int(got[i]) - w), 1) << "add element " << i;
    } else {
      EXPECT_EQ(int(got[i]), w) << "add element " << i << " (" << v << ")";
    }
  }
  // In place (output aliases a) gives the same bytes.
  std::vector<int8_t> alias = a.q;
  args.a.data = alias.data();
  args.out.data = alias.data();
  add_i8_ref(args);
  EXPECT_EQ(alias, got);
}

TEST(NnLayers, ConcatAgainstFloatAndExactCopy) {
  std::mt19937 rng(6);
  Q a = random_q(3, 4, 2, 0.05f, 3, rng), b = random_q(3, 4, 5, 0.08f, 0, rng);
  const float os = 0.08f;
  std::vector<int8_t> got(3 * 4 * 7), want(got.size());
  ConcatArgs args;
  args.count = 2;
  args.in[0] = a.view(); args.in[1] = b.view();
  args.rq[0] = rq_of(double(a.scale) / os);
  args.rq[1] = rq_of(double(b.scale) / os);
  args.out = {got.data(), 3, 4, 7, 0};
  concat_i8_ref(args);
  for (int p = 0; p < 12; ++p) {
    for (int c = 0; c < 2; ++c) want[p * 7 + c] = quantize_ref(a.real(p * 2 + c), os, 0);
    for (int c = 0; c < 5; ++c) want[p * 7 + 2 + c] = quantize_ref(b.real(p * 5 + c), os, 0);
  }
  compare_lsb(got, want, "concat");
  // Same quantisation in and out: an exact copy (multiplier 1 is exact).
  for (int p = 0; p < 12; ++p)
    for (int c = 0; c < 5; ++c) EXPECT_EQ(got[p * 7 + 2 + c], b.q[p * 5 + c]);
}

TEST(NnLayers, ClampExact) {
  std::mt19937 rng(7);
  Q a = random_q(4, 4, 3, 0.1f, -10, rng);
  std::vector<int8_t> got(a.q.size());
  ClampArgs args;
  args.in = a.view();
  args.out = {got.data(), 4, 4, 3, -10};
  args.out_min = -10; args.out_max = 50;  // ReLU6 at scale 0.1: 6 / 0.1 = 60 above the zero point
  clamp_i8_ref(args);
  for (size_t i = 0; i < got.size(); ++i) EXPECT_EQ(got[i], std::clamp<int>(a.q[i], -10, 50));
}

TEST(NnLayers, PoolsAgainstFloat) {
  std::mt19937 rng(8);
  Q a = random_q(7, 6, 3, 0.1f, 5, rng);
  // Max 3x3 stride 2 pad 1: exact.
  const int oh = (7 + 2 - 3) / 2 + 1, ow = (6 + 2 - 3) / 2 + 1;
  std::vector<int8_t> got(size_t(oh) * ow * 3);
  PoolArgs p;
  p.in = a.view();
  p.out = {got.data(), oh, ow, 3, 5};
  p.kernel_h = p.kernel_w = 3; p.stride_h = p.stride_w = 2; p.pad_top = p.pad_left = 1;
  maxpool_i8_ref(p);
  auto window = [&](int oy, int ox, int c, auto&& f) {
    for (int ky = 0; ky < 3; ++ky)
      for (int kx = 0; kx < 3; ++kx) {
        const int iy = oy * 2 - 1 + ky, ix = ox * 2 - 1 + kx;
        if (iy >= 0 && ix >= 0 && iy < 7 && ix < 6) f(a.q[(size_t(iy) * 6 + ix) * 3 + c]);
      }
  };
  for (int oy = 0; oy < oh; ++oy)
    for (int ox = 0; ox < ow; ++ox)
      for (int c = 0; c < 3; ++c) {
        int m = -128;
        window(oy, ox, c, [&](int v) { m = std::max(m, v); });
        EXPECT_EQ(got[(size_t(oy) * ow + ox) * 3 + c], m);
      }
  // Average, requantised to another scale; count excludes padding.
  const float os = 0.07f;
  std::vector<Requant> by_count(9);
  for (int k = 1; k <= 9; ++k) by_count[k - 1] = rq_of(double(a.scale) / os / k);
  p.requant_by_count = by_count.data();
  p.out.zero_point = -3;
  avgpool_i8_ref(p);
  std::vector<int8_t> want(got.size());
  for (int oy = 0; oy < oh; ++oy)
    for (int ox = 0; ox < ow; ++ox)
      for (int c = 0; c < 3; ++c) {
        double sum = 0;
        int n = 0;
        window(oy, ox, c, [&](int v) { sum += a.scale * (v - 5); ++n; });
        want[(size_t(oy) * ow + ox) * 3 + c] = quantize_ref(sum / n, os, -3);
      }
  compare_lsb(got, want, "avgpool");
}

TEST(NnLayers, UpsampleNearestExactBilinearAgainstFloat) {
  std::mt19937 rng(9);
  for (int f : {1, 2, 3, 4}) {
    Q a = random_q(3, 5, 2, 0.1f, 0, rng);
    const int oh = 3 * f, ow = 5 * f;
    std::vector<int8_t> got(size_t(oh) * ow * 2);
    UpsampleArgs u;
    u.in = a.view();
    u.out = {got.data(), oh, ow, 2, 0};
    u.factor = f;
    upsample_nearest_i8_ref(u);
    for (int y = 0; y < oh; ++y)
      for (int x = 0; x < ow; ++x)
        for (int c = 0; c < 2; ++c) EXPECT_EQ(got[(size_t(y) * ow + x) * 2 + c], a.q[(size_t(y / f) * 5 + x / f) * 2 + c]);
    upsample_bilinear_i8_ref(u);
    // Float bilinear with half-pixel centres, clamped at the border (as OpenCV INTER_LINEAR and
    // PyTorch align_corners=False). Integer weights are exact, so only the final rounding differs.
    auto src = [&](int o, int n, int& i0, int& i1, double& t) {
      double s = (o + 0.5) / f - 0.5;
      if (s < 0) s = 0;
      i0 = int(std::floor(s));
      t = s - i0;
      i1 = std::min(i0 + 1, n - 1);
    };
    for (int y = 0; y < oh; ++y)
      for (int x = 0; x < ow; ++x) {
        int y0, y1, x0, x1;
        double ty, tx;
        src(y, 3, y0, y1, ty);
        src(x, 5, x0, x1, tx);
        for (int c = 0; c < 2; ++c) {
          auto q = [&](int yy, int xx) { return double(a.q[(size_t(yy) * 5 + xx) * 2 + c]); };
          const double v = (1 - ty) * ((1 - tx) * q(y0, x0) + tx * q(y0, x1)) + ty * ((1 - tx) * q(y1, x0) + tx * q(y1, x1));
          // v is a multiple of 1/(2f)^2 in exact arithmetic; recover that numerator, then round half up.
          const double denom = 4.0 * f * f;
          const int want = int(std::floor((std::round(v * denom) + denom / 2) / denom));
          EXPECT_EQ(got[(size_t(y) * ow + x) * 2 + c], want) << "f=" << f << " y=" << y << " x=" << x;
        }
      }
  }
}

TEST(NnLayers, SoftmaxAgainstFloat) {
  std::mt19937 rng(10);
  Q a = random_q(4, 3, 13, 0.125f, -3, rng);
  std::vector<float> table(256), got(a.q.size());
  for (int d = 0; d < 256; ++d) table[d] = static_cast<float>(std::exp(-0.125 * d));
  SoftmaxArgs s;
  s.in = a.view();
  s.out = got.data();
  s.exp_table = table.data();
  softmax_i8_ref(s);
  for (int p = 0; p < 12; ++p) {
    double sum = 0, mx = -1e9;
    for (int c = 0; c < 13; ++c) mx = std::max(mx, a.real(p * 13 + c));
    for (int c = 0; c < 13; ++c) sum += std::exp(a.real(p * 13 + c) - mx);
    float total = 0;
    for (int c = 0; c < 13; ++c) {
      EXPECT_NEAR(got[p * 13 + c], std::exp(a.real(p * 13 + c) - mx) / sum, 1e-6);
      total += got[p * 13 + c];
    }
    EXPECT_NEAR(total, 1.0f, 1e-5f);
  }
}

}  // namespace
}  // namespace ef::nn
