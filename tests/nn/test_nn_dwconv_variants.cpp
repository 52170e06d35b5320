// Every dwconv_i8 variant the CPU can run (nn/conv_kernels.h, kDwConvI8Variants) against the
// specification dwconv2d_i8_ref, byte for byte: random shapes around the SIMD block widths (8 to 64),
// large kernels, strides, dilations and windows wholly in the padding, output row ranges (rows
// outside the range untouched), saturation both ways and multipliers at and next to rounding ties.
// Tensors live in exact-size heap buffers and the packed weights in an exact-size 64-byte-aligned
// one, so any read or write past a tensor is a heap overflow under ASan.
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <new>
#include <random>
#include <string>
#include <vector>

#include "kernels/kernel_test_util.h"
#include "nn/conv_kernels.h"

namespace ef::nn {
namespace {

using Variant = kernels::KernelVariant<ConvKernelPtr>;

// The runnable variants, reported once per test binary run (the reference row included).
const std::vector<const Variant*>& variants() {
  static const std::vector<const Variant*> v = ef::test::runnable_variants(kDwConvI8Variants, "dwconv_i8");
  return v;
}

// One layer: input h x w x c, kernel, stride, dilation, pads (before and after, per axis), zero
// points and the output range.
struct DwCase {
  int h = 1, w = 1, c = 1;
  int kh = 1, kw = 1, sh = 1, sw = 1, dh = 1, dw = 1;
  int pt = 0, pl = 0, pb = 0, pr = 0;
  int32_t zin = 0, zout = 0, omin = -128, omax = 127;

  int out_h() const { return (h + pt + pb - (dh * (kh - 1) + 1)) / sh + 1; }
  int out_w() const { return (w + pl + pr - (dw * (kw - 1) + 1)) / sw + 1; }
  std::string str() const {
    return "in " + std::to_string(h) + "x" + std::to_string(w) + "x" + std::to_string(c) + " k " + std::to_string(kh) +
           "x" + std::to_string(kw) + " s " + std::to_string(sh) + "," + std::to_string(sw) + " d " +
           std::to_string(dh) + "," + std::to_string(dw) + " pad t" + std::to_string(pt) + " l" + std::to_string(pl) +
           " b" + std::to_string(pb) + " r" + std::to_string(pr) + " zin " + std::to_string(zin) + " zout " +
           std::to_string(zout) + " out [" + std::to_string(omin) + "," + std::to_string(omax) + "]";
  }
};

// The layer's data, each array exactly as long as the tensor it holds.
struct DwData {
  std::vector<int8_t> in, weights;
  std::vector<int32_t> bias;
  std::vector<Requant> rq;
};

// Random data; multipliers log-uniform in [2^lo_exp, 2^hi_exp]. Weights avoid -128 (the loader
// rejects it, docs/model_format.md WGHT).
DwData random_data(const DwCase& k, std::mt19937& rng, int32_t bias_abs = 20000, float lo_exp = -13,
                   float hi_exp = -5) {
  std::uniform_int_distribution<int> q(-128, 127), wt(-127, 127), b(-bias_abs, bias_abs);
  std::uniform_real_distribution<float> e(lo_exp, hi_exp);
  DwData d;
  d.in.resize(std::size_t(k.h) * k.w * k.c);
  d.weights.resize(std::size_t(k.c) * k.kh * k.kw);
  d.bias.resize(k.c);
  d.rq.resize(k.c);
  for (auto& v : d.in) v = static_cast<int8_t>(q(rng));
  for (auto& v : d.weights) v = static_cast<int8_t>(wt(rng));
  for (auto& v : d.bias) v = b(rng);
  for (auto& r : d.rq) r.multiplier = std::exp2(e(rng));
  return d;
}

ConvArgs args_for(const DwCase& k, const DwData& d, int8_t* out) {
  ConvArgs a;
  a.in = {d.in.data(), k.h, k.w, k.c, k.zin};
  a.out = {out, k.out_h(), k.out_w(), k.c, k.zout};
  a.kernel_h = k.kh; a.kernel_w = k.kw;
  a.stride_h = k.sh; a.stride_w = k.sw;
  a.dilation_h = k.dh; a.dilation_w = k.dw;
  a.pad_top = k.pt; a.pad_left = k.pl;
  a.weights = d.weights.data();
  a.bias = d.bias.data();
  a.requant = d.rq.data();
  a.out_min = k.omin; a.out_max = k.omax;
  return a;
}

// A variant's packed weights in an exact-size, 64-byte-aligned heap block (empty for the reference).
class Packed {
 public:
  Packed(const ConvKernel& kernel, const DwCase& k, const DwData& d) {
    ConvShape shape;
    shape.in_c = shape.out_c = k.c;
    shape.kernel_h = k.kh; shape.kernel_w = k.kw;
    shape.in_zero_point = k.zin;
    bytes_ = kernel.packed_bytes(shape);
    if (bytes_ == 0) return;
    data_ = ::operator new(bytes_, std::align_val_t{64});
    kernel.pack(shape, ConvParams{d.weights.data(), d.bias.data(), d.rq.data()}, data_);
  }
  ~Packed() {
    if (data_) ::operator delete(data_, std::align_val_t{64});
  }
  Packed(const Packed&) = delete;
  Packed& operator=(const Packed&) = delete;
  const void* data() const { return data_; }

 private:
  std::size_t bytes_ = 0;
  void* data_ = nullptr;
};

std::vector<int8_t> reference(const DwCase& k, const DwData& d) {
  std::vector<int8_t> out(std::size_t(k.out_h()) * k.out_w() * k.c);
  dwconv2d_i8_ref(args_for(k, d, out.data()));
  return out;
}

// "" when equal, else where the first difference is.
std::string first_difference(const DwCase& k, const std::vector<int8_t>& got, const std::vector<int8_t>& want) {
  for (std::size_t i = 0; i < want.size(); ++i) {
    if (got[i] == want[i]) continue;
    const std::size_t px = i / k.c;
    return "first difference at y " + std::to_string(px / k.out_w()) + " x " + std::to_string(px % k.out_w()) +
           " c " + std::to_string(i % k.c) + ": got " + std::to_string(got[i]) + ", want " + std::to_string(want[i]);
  }
  return "";
}

// Every runnable variant over all rows equals the reference.
void expect_all_variants_match(const DwCase& k, const DwData& d, const std::string& what) {
  ASSERT_GE(k.out_h(), 1) << k.str();
  ASSERT_GE(k.out_w(), 1) << k.str();
  const std::vector<int8_t> want = reference(k, d);
  for (const Variant* v : variants()) {
    const Packed packed(*v->fn, k, d);
    std::vector<int8_t> got(want.size(), int8_t{0x5A});
    ConvArgs a = args_for(k, d, got.data());
    a.packed = packed.data();
    v->fn->run(a);
    const std::string diff = first_difference(k, got, want);
    ASSERT_TRUE(diff.empty()) << v->name << " differs from dwconv2d_i8_ref (" << what << "): " << k.str() << "; "
                              << diff;
  }
}

// Random zero points and one of: the full range, ReLU, a ReLU6-like range, a random narrow range.
void random_quantisation(DwCase& k, std::mt19937& rng) {
  std::uniform_int_distribution<int> zp(-128, 127), pick(0, 3);
  k.zin = zp(rng);
  k.zout = zp(rng);
  switch (pick(rng)) {
    case 0: k.omin = -128; k.omax = 127; break;
    case 1: k.omin = k.zout; k.omax = 127; break;
    case 2: k.omin = k.zout; k.omax = k.zout + 85 > 127 ? 127 : k.zout + 85; break;  // 6 / 0.07
    default: {
      std::uniform_int_distribution<int> lo(-128, 100);
      k.omin = lo(rng);
      k.omax = k.omin + std::uniform_int_distribution<int>(0, 127 - k.omin)(rng);
    }
  }
}

// Input size along one axis: random in [1, max_in], raised until the window fits at least once.
int fit_input(int random_in, int kernel, int dilation, int pad_before, int pad_after) {
  const int extent = dilation * (kernel - 1) + 1;
  const int needed = extent - pad_before - pad_after;
  return random_in < needed ? needed : random_in;
}

// Around 8, 16 (the 16-bit layout's blocks) and 32, 64 (the byte layout's ymm / zmm blocks of
// dwconv_i8__avx512vnni), and the model's 24, 48, 96.
const int kChannels[] = {1, 3, 7, 8, 15, 16, 17, 24, 31, 32, 33, 47, 48, 63, 64, 65, 96, 127, 128, 129};

TEST(NnDwConvVariants, ReportVariants) { EXPECT_FALSE(variants().empty()); }

TEST(NnDwConvVariants, RandomShapes) {
  std::mt19937 rng(20240611);
  std::uniform_int_distribution<int> size(1, 9), coin(0, 3);
  int cases = 0;
  for (int c : kChannels)
    for (int kernel : {1, 3, 5})
      for (int stride : {1, 2})
        for (int dilation : {1, 2}) {
          DwCase k;
          k.c = c;
          k.kh = k.kw = kernel;
          k.sh = k.sw = stride;
          k.dh = k.dw = dilation;
          // One case in four has a different width axis, so h/w mix-ups show.
          if (coin(rng) == 0) {
            const int other[] = {1, 3, 5};
            k.kw = other[std::uniform_int_distribution<int>(0, 2)(rng)];
            k.sw = 3 - stride;
          }
          const auto pad = [&](int kn, int dl) { return std::uniform_int_distribution<int>(0, dl * (kn - 1) / 2 + 1)(rng); };
          k.pt = pad(k.kh, k.dh); k.pb = pad(k.kh, k.dh);
          k.pl = pad(k.kw, k.dw); k.pr = pad(k.kw, k.dw);
          k.h = fit_input(size(rng), k.kh, k.dh, k.pt, k.pb);
          k.w = fit_input(size(rng), k.kw, k.dw, k.pl, k.pr);
          random_quantisation(k, rng);
          const DwData d = random_data(k, rng);
          expect_all_variants_match(k, d, "random shape " + std::to_string(cases++));
          if (HasFatalFailure()) return;
        }
}

TEST(NnDwConvVariants, LargeKernelsStridesDilations) {
  std::mt19937 rng(77);
  struct Geometry { int h, w, c, kh, kw, sh, sw, dh, dw, pt, pl, pb, pr; };
  const Geometry cases[] = {
      {12, 13, 24, 7, 7, 1, 1, 1, 1, 3, 3, 3, 3},        // 7x7 "same"
      {9, 30, 16, 1, 9, 1, 3, 1, 2, 0, 8, 0, 8},         // 1 x 9, stride 3, dilation 2 along x only
      {25, 6, 40, 11, 3, 2, 1, 2, 1, 10, 1, 10, 1},      // 11 x 3
      {20, 20, 9, 3, 3, 8, 8, 1, 1, 1, 1, 1, 1},         // the largest stride
      {40, 37, 17, 3, 3, 1, 2, 16, 16, 16, 16, 16, 16},  // the largest dilation
      {5, 6, 33, 3, 3, 1, 1, 1, 1, 64, 64, 64, 64},      // the largest pads: many windows wholly outside
      {33, 34, 9, 31, 31, 4, 4, 1, 1, 15, 15, 15, 15},   // the largest kernel, odd tap count 961
      {8, 8, 18, 2, 2, 2, 2, 1, 1, 0, 0, 0, 0},          // an even tap count
  };
  for (const Geometry& g : cases) {
    DwCase k;
    k.h = g.h; k.w = g.w; k.c = g.c;
    k.kh = g.kh; k.kw = g.kw; k.sh = g.sh; k.sw = g.sw; k.dh = g.dh; k.dw = g.dw;
    k.pt = g.pt; k.pl = g.pl; k.pb = g.pb; k.pr = g.pr;
    random_quantisation(k, rng);
    // Larger sums need smaller multipliers to stay off the clamps.
    const DwData d = random_data(k, rng, 20000, -17, -8);
    expect_all_variants_match(k, d, "large geometry");
    if (HasFatalFailure()) return;
  }
}

// The model's depthwise layers (bench/nn_conv.cpp) and wider rows, so that runs of interior pixels
// (processed two at a time by some variants) and their odd leftovers both occur.
TEST(NnDwConvVariants, ModelShapes) {
  std::mt19937 rng(2468);
  struct Geometry { int h, w, c, k, s, d; };
  const Geometry cases[] = {{60, 80, 24, 3, 2, 1}, {30, 40, 48, 3, 1, 1}, {30, 40, 48, 3, 2, 1},
                            {15, 20, 96, 3, 1, 2}, {13, 23, 24, 3, 1, 1}, {11, 21, 80, 5, 1, 1},
                            {9, 17, 112, 3, 2, 1}, {7, 19, 160, 3, 1, 1}};
  for (const Geometry& g : cases) {
    DwCase k;
    k.h = g.h; k.w = g.w; k.c = g.c;
    k.kh = k.kw = g.k; k.sh = k.sw = g.s; k.dh = k.dw = g.d;
    k.pt = k.pl = k.pb = k.pr = g.d * (g.k - 1) / 2;
    random_quantisation(k, rng);
    const DwData d = random_data(k, rng);
    expect_all_variants_match(k, d, "model shape");
    if (HasFatalFailure()) return;
  }
}

// The depthwise layers of models/deeplabv3-mnv2-nyu13.efm (issue 28) at their own sizes: stride 2 on
// odd inputs, dilation 2 with padding 2 on 384 and 576 channels, dilation 4 with padding 4 on 960,
// and 304 channels (the decoder's, not a multiple of 64).
TEST(NnDwConvVariants, DeepLabShapes) {
  std::mt19937 rng(1357);
  struct Geometry { int h, w, c, s, d; };
  const Geometry cases[] = {{97, 129, 32, 1, 1}, {97, 129, 96, 2, 1},  {49, 65, 144, 2, 1}, {25, 33, 192, 1, 1},
                            {25, 33, 384, 1, 2}, {25, 33, 576, 1, 2},  {25, 33, 960, 1, 4}, {49, 65, 304, 1, 1},
                            {9, 11, 960, 1, 4},  {5, 13, 384, 1, 2}};
  for (const Geometry& g : cases) {
    DwCase k;
    k.h = g.h; k.w = g.w; k.c = g.c;
    k.kh = k.kw = 3; k.sh = k.sw = g.s; k.dh = k.dw = g.d;
    k.pt = k.pl = k.pb = k.pr = g.d;
    random_quantisation(k, rng);
    const DwData d = random_data(k, rng);
    expect_all_variants_match(k, d, "DeepLab shape");
    if (HasFatalFailure()) return;
  }
}

TEST(NnDwConvVariants, RowRanges) {
  std::mt19937 rng(4242);
  struct Geometry { int h, w, c, k, s, d, pad; };
  const Geometry cases[] = {{9, 7, 17, 3, 1, 1, 1}, {11, 6, 33, 3, 2, 1, 1}, {10, 9, 48, 5, 1, 2, 4},
                            {6, 5, 8, 1, 1, 1, 0}};
  for (const Geometry& g : cases) {
    DwCase k;
    k.h = g.h; k.w = g.w; k.c = g.c;
    k.kh = k.kw = g.k; k.sh = k.sw = g.s; k.dh = k.dw = g.d;
    k.pt = k.pl = k.pb = k.pr = g.pad;
    random_quantisation(k, rng);
    const DwData d = random_data(k, rng);
    const std::vector<int8_t> want = reference(k, d);
    const int oh = k.out_h();
    const std::size_t row_bytes = std::size_t(k.out_w()) * k.c;
    const int ranges[][2] = {{0, 1}, {1, 3}, {oh - 1, oh}, {2, oh - 1}, {0, oh}, {3, 3}};
    for (const Variant* v : variants()) {
      const Packed packed(*v->fn, k, d);
      for (const auto& r : ranges) {
        // Rows outside the range must keep these bytes.
        std::vector<int8_t> got(want.size());
        for (auto& b : got) b = static_cast<int8_t>(rng());
        const std::vector<int8_t> before = got;
        ConvArgs a = args_for(k, d, got.data());
        a.packed = packed.data();
        a.oy_begin = r[0];
        a.oy_end = r[1];
        v->fn->run(a);
        for (int y = 0; y < oh; ++y) {
          const std::vector<int8_t>& expected = (y >= r[0] && y < r[1]) ? want : before;
          for (std::size_t i = y * row_bytes; i < (y + 1) * row_bytes; ++i)
            ASSERT_EQ(got[i], expected[i]) << v->name << " rows [" << r[0] << ", " << r[1] << "): byte " << i
                                           << " of row " << y << ", " << k.str();
        }
      }
      // Three consecutive ranges, as a thread pool would split the layer, give the whole output.
      std::vector<int8_t> got(want.size(), int8_t{0x5A});
      ConvArgs a = args_for(k, d, got.data());
      a.packed = packed.data();
      const int cuts[] = {0, oh / 3, 2 * oh / 3, oh};
      for (int i = 0; i < 3; ++i) {
        a.oy_begin = cuts[i];
        a.oy_end = cuts[i + 1];
        v->fn->run(a);
      }
      ASSERT_EQ(first_difference(k, got, want), "") << v->name << " split in three row ranges, " << k.str();
    }
  }
}

TEST(NnDwConvVariants, Saturation) {
  std::mt19937 rng(99);
  for (int c : {5, 8, 16, 23, 48, 96, 100}) {
    DwCase k;
    k.h = 5; k.w = 6; k.c = c;
    k.kh = k.kw = 3;
    k.pt = k.pl = k.pb = k.pr = 1;
    random_quantisation(k, rng);
    DwData d = random_data(k, rng);
    // Biases at the loader's bound 2^30, alternating in sign, with multipliers from 1 to just below
    // 2^24: every output sits on one of the clamps (both clamps across channels).
    for (int ch = 0; ch < c; ++ch) {
      d.bias[ch] = (ch % 2) ? (1 << 30) : -(1 << 30);
      d.rq[ch].multiplier = (ch % 3 == 0) ? 1.0f : (ch % 3 == 1) ? 1024.0f : 16777215.0f;
    }
    expect_all_variants_match(k, d, "huge biases");
    if (HasFatalFailure()) return;
    // Ordinary biases, multipliers so large that any nonzero sum saturates, and the smallest normal
    // multiplier, under which every output is the zero point clamped into the range.
    for (int ch = 0; ch < c; ++ch) d.rq[ch].multiplier = (ch % 2) ? 65536.0f : FLT_MIN;
    expect_all_variants_match(k, d, "huge and tiny multipliers");
    if (HasFatalFailure()) return;
  }
}

TEST(NnDwConvVariants, RoundingTies) {
  std::mt19937 rng(31337);
  // Exact powers of two make float(acc) * m land on halves (ties, rounded to even), and their float
  // neighbours land just beside the halves; 1.5 and 0.75 give ties from odd and from even sums.
  const float half = 0.5f;
  const float multipliers[] = {half, std::nextafter(half, 0.0f), std::nextafter(half, 1.0f), 0.25f, 0.125f,
                               0.0625f, 1.5f, 0.75f, std::nextafter(0.25f, 0.0f), std::nextafter(0.25f, 1.0f)};
  for (int c : {7, 16, 19, 40, 72}) {
    for (int kernel : {1, 3}) {
      DwCase k;
      k.h = 4; k.w = 7; k.c = c;
      k.kh = k.kw = kernel;
      k.pt = k.pl = k.pb = k.pr = kernel / 2;
      k.zin = 3;
      k.zout = -2;
      // Small weights and inputs keep |acc| small, so the halves stay inside the output range.
      DwData d = random_data(k, rng, 40);
      std::uniform_int_distribution<int> small_w(-2, 2), small_q(-20, 20);
      for (auto& w : d.weights) w = static_cast<int8_t>(small_w(rng));
      for (auto& q : d.in) q = static_cast<int8_t>(small_q(rng));
      for (int ch = 0; ch < c; ++ch) d.rq[ch].multiplier = multipliers[ch % 10];
      expect_all_variants_match(k, d, "multipliers at rounding ties");
      if (HasFatalFailure()) return;
    }
  }
}

}  // namespace
}  // namespace ef::nn
