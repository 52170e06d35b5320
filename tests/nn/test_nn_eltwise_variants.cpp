// Every add_i8, maxpool_i8, avgpool_i8, clamp_i8 and concat_i8 variant the CPU can run
// (nn/eltwise_kernels.h) against the specifications add_i8_ref, maxpool_i8_ref, avgpool_i8_ref,
// clamp_i8_ref and concat_i8_ref, byte for byte.
// add: flat sizes 0..130 and odd large ones, random shapes, zero points, multipliers (log-uniform,
// saturating, and ma = mb = 0.5 so that half the sums are rounding ties), narrowed output ranges,
// and in-place operation (out == a, out == b). maxpool: channels 1..70 (around 8/16/32/64), 2x2 s2,
// 3x3 s2 pad 1, 3x3 s1 pad 1, asymmetric kernels / strides / pads, global windows up to 31, inputs
// full of -128. avgpool: the same windows with random zero points and the loader's multipliers per
// window size, tie-producing and saturating scale ratios, inputs at -128 / 127. clamp: flat sizes
// 0..130 and large ones, random and degenerate ranges, in place. concat: 1..16 inputs, channels
// around the vector widths, copies (same quantisation), requantisations (random, ties, saturating)
// and both mixed, 1x1 and odd spatial sizes. Tensors live in exact-size heap buffers, so any read
// or write past one is a heap overflow under ASan.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "kernels/kernel_test_util.h"
#include "nn/eltwise_kernels.h"
#include "nn/nn_test_util.h"

namespace ef::nn {
namespace {

using AddVariant = kernels::KernelVariant<AddI8Fn>;
using PoolVariant = kernels::KernelVariant<PoolI8Fn>;
using ClampVariant = kernels::KernelVariant<ClampI8Fn>;
using ConcatVariant = kernels::KernelVariant<ConcatI8Fn>;

const std::vector<const AddVariant*>& add_variants() {
  static const std::vector<const AddVariant*> v = ef::test::runnable_variants(kAddI8Variants, "add_i8");
  return v;
}
const std::vector<const PoolVariant*>& pool_variants() {
  static const std::vector<const PoolVariant*> v = ef::test::runnable_variants(kMaxPoolI8Variants, "maxpool_i8");
  return v;
}
const std::vector<const PoolVariant*>& avgpool_variants() {
  static const std::vector<const PoolVariant*> v = ef::test::runnable_variants(kAvgPoolI8Variants, "avgpool_i8");
  return v;
}
const std::vector<const ClampVariant*>& clamp_variants() {
  static const std::vector<const ClampVariant*> v = ef::test::runnable_variants(kClampI8Variants, "clamp_i8");
  return v;
}
const std::vector<const ConcatVariant*>& concat_variants() {
  static const std::vector<const ConcatVariant*> v = ef::test::runnable_variants(kConcatI8Variants, "concat_i8");
  return v;
}

std::vector<int8_t> random_bytes(std::size_t n, std::mt19937& rng, int lo = -128, int hi = 127) {
  std::uniform_int_distribution<int> d(lo, hi);
  std::vector<int8_t> v(n);
  for (auto& x : v) x = static_cast<int8_t>(d(rng));
  return v;
}

// ---------------------------------------------------------------------------------------------- add

struct AddCase {
  int h = 1, w = 1, c = 1;
  int32_t za = 0, zb = 0, zo = 0, omin = -128, omax = 127;
  float ma = 1.0f, mb = 1.0f;
  std::size_t n() const { return std::size_t(h) * w * c; }
  std::string str() const {
    return std::to_string(h) + "x" + std::to_string(w) + "x" + std::to_string(c) + " za " + std::to_string(za) +
           " zb " + std::to_string(zb) + " zo " + std::to_string(zo) + " ma " + std::to_string(ma) + " mb " +
           std::to_string(mb) + " out [" + std::to_string(omin) + "," + std::to_string(omax) + "]";
  }
};

AddArgs make_add(const AddCase& k, const int8_t* a, const int8_t* b, int8_t* out) {
  AddArgs x;
  x.a = TensorI8{a, k.h, k.w, k.c, k.za};
  x.b = TensorI8{b, k.h, k.w, k.c, k.zb};
  x.out = MutTensorI8{out, k.h, k.w, k.c, k.zo};
  x.rq_a.multiplier = k.ma;
  x.rq_b.multiplier = k.mb;
  x.out_min = k.omin;
  x.out_max = k.omax;
  return x;
}

// Runs every variant on the case (separate output, out == a, out == b) against the reference.
void check_add(const AddCase& k, std::mt19937& rng) {
  const std::size_t n = k.n();
  const std::vector<int8_t> a = random_bytes(n, rng), b = random_bytes(n, rng);
  std::vector<int8_t> want(n);
  add_i8_ref(make_add(k, a.data(), b.data(), want.data()));
  for (const AddVariant* v : add_variants()) {
    SCOPED_TRACE(std::string(v->name) + " " + k.str());
    {
      std::vector<int8_t> got(n, 0x55);
      v->fn(make_add(k, a.data(), b.data(), got.data()));
      ASSERT_EQ(got, want) << "separate output";
    }
    {
      std::vector<int8_t> io = a;  // out == a
      v->fn(make_add(k, io.data(), b.data(), io.data()));
      ASSERT_EQ(io, want) << "out aliases a";
    }
    {
      std::vector<int8_t> io = b;  // out == b
      v->fn(make_add(k, a.data(), io.data(), io.data()));
      ASSERT_EQ(io, want) << "out aliases b";
    }
  }
}

float log_uniform(std::mt19937& rng, float lo_exp, float hi_exp) {
  return std::exp2(std::uniform_real_distribution<float>(lo_exp, hi_exp)(rng));
}

AddCase random_add_case(std::mt19937& rng, std::size_t n) {
  AddCase k;
  k.h = 1;
  k.w = 1;
  k.c = static_cast<int>(n);
  std::uniform_int_distribution<int> zp(-128, 127);
  k.za = zp(rng);
  k.zb = zp(rng);
  k.zo = zp(rng);
  k.ma = log_uniform(rng, -4, 1);
  k.mb = log_uniform(rng, -4, 1);
  switch (rng() % 4) {
    case 0: break;
    case 1: k.omin = k.zo; break;  // fused ReLU
    case 2: k.omin = std::max(-128, k.zo - 20); k.omax = std::min(127, k.zo + 20); break;
    default: k.omin = -100; k.omax = 90; break;
  }
  if (k.omin > k.omax) k.omin = k.omax;
  return k;
}

TEST(EltwiseVariants, AddFlatSizes) {
  std::mt19937 rng(1234);
  for (std::size_t n = 0; n <= 130; ++n) check_add(random_add_case(rng, n), rng);
  for (std::size_t n : {255u, 257u, 1001u, 4097u, 65537u}) check_add(random_add_case(rng, n), rng);
}

TEST(EltwiseVariants, AddShapes) {
  std::mt19937 rng(99);
  std::uniform_int_distribution<int> hw(1, 9), ch(1, 70);
  for (int it = 0; it < 60; ++it) {
    AddCase k = random_add_case(rng, 1);
    k.h = hw(rng);
    k.w = hw(rng);
    k.c = ch(rng);
    check_add(k, rng);
  }
}

TEST(EltwiseVariants, AddRoundingTies) {
  std::mt19937 rng(7);
  for (std::size_t n : {1u, 15u, 16u, 17u, 31u, 33u, 63u, 64u, 65u, 129u, 1023u}) {
    for (int32_t zo : {-128, -3, 0, 5, 127}) {
      AddCase k = random_add_case(rng, n);
      k.ma = k.mb = 0.5f;  // (a - za + b - zb) / 2: every odd sum is a tie
      k.zo = zo;
      k.omin = -128;
      k.omax = 127;
      check_add(k, rng);
      k.ma = 0.25f;  // quarter steps: ties at .5 only, others at .25 / .75
      k.mb = 0.75f;
      check_add(k, rng);
      k.ma = 1.5f;
      k.mb = 0.5f;
      check_add(k, rng);
    }
  }
}

// docs/model_format.md 3.3 rounds each product to float32 before the sum. Here the exact value of
// (a - za) * ma + (b - zb) * mb is just below 19.5 but the rounded products sum to exactly 19.5,
// which rounds half to even to 20; a fused multiply-add (one rounding) gives 19. Every variant and
// the reference must give 20 (the nn module is built with -ffp-contract=off for this).
TEST(EltwiseVariants, AddRoundsEachProductBeforeTheSum) {
  AddCase k;
  k.c = 67;  // full vectors of every width and a tail
  k.za = -75;
  k.zb = 101;
  k.ma = 0.391225904f;
  k.mb = 0.0739181936f;
  const volatile float pa = float(-21 - k.za) * k.ma;  // volatile: the test's own sum stays unfused
  const volatile float pb = float(79 - k.zb) * k.mb;
  ASSERT_EQ(pa + pb, 19.5f) << "the case no longer exercises a tie";
  const std::vector<int8_t> a(k.n(), -21), b(k.n(), 79);
  std::vector<int8_t> got(k.n());
  add_i8_ref(make_add(k, a.data(), b.data(), got.data()));
  ASSERT_EQ(got, std::vector<int8_t>(k.n(), 20)) << "reference";
  for (const AddVariant* v : add_variants()) {
    std::fill(got.begin(), got.end(), int8_t{0});
    v->fn(make_add(k, a.data(), b.data(), got.data()));
    EXPECT_EQ(got, std::vector<int8_t>(k.n(), 20)) << v->name;
  }
}

TEST(EltwiseVariants, AddSaturation) {
  std::mt19937 rng(8);
  for (std::size_t n : {1u, 16u, 47u, 64u, 100u, 777u}) {
    for (float m : {4.0f, 16.0f, 200.0f, 65536.0f}) {
      AddCase k = random_add_case(rng, n);
      k.ma = m;
      k.mb = m * 0.75f;
      check_add(k, rng);
      k.mb = 1.0f / m;  // one large, one small multiplier
      check_add(k, rng);
    }
  }
}

// ------------------------------------------------------------------------------------------ maxpool

struct PoolCase {
  int h = 1, w = 1, c = 1;
  int kh = 1, kw = 1, sh = 1, sw = 1, pt = 0, pl = 0, pb = 0, pr = 0;
  int out_h() const { return (h + pt + pb - kh) / sh + 1; }
  int out_w() const { return (w + pl + pr - kw) / sw + 1; }
  std::string str() const {
    return "in " + std::to_string(h) + "x" + std::to_string(w) + "x" + std::to_string(c) + " k " +
           std::to_string(kh) + "x" + std::to_string(kw) + " s " + std::to_string(sh) + "," + std::to_string(sw) +
           " pad t" + std::to_string(pt) + " l" + std::to_string(pl) + " b" + std::to_string(pb) + " r" +
           std::to_string(pr);
  }
};

void check_pool(const PoolCase& k, std::mt19937& rng, bool all_min = false) {
  ASSERT_GE(k.h + k.pt + k.pb, k.kh) << k.str();
  ASSERT_GE(k.w + k.pl + k.pr, k.kw) << k.str();
  const int oh = k.out_h(), ow = k.out_w();
  const std::size_t in_n = std::size_t(k.h) * k.w * k.c, out_n = std::size_t(oh) * ow * k.c;
  const std::vector<int8_t> in = all_min ? std::vector<int8_t>(in_n, -128) : random_bytes(in_n, rng);
  PoolArgs p;
  p.in = TensorI8{in.data(), k.h, k.w, k.c, 0};
  p.kernel_h = k.kh;
  p.kernel_w = k.kw;
  p.stride_h = k.sh;
  p.stride_w = k.sw;
  p.pad_top = k.pt;
  p.pad_left = k.pl;
  std::vector<int8_t> want(out_n);
  p.out = MutTensorI8{want.data(), oh, ow, k.c, 0};
  maxpool_i8_ref(p);
  for (const PoolVariant* v : pool_variants()) {
    SCOPED_TRACE(std::string(v->name) + " " + k.str());
    std::vector<int8_t> got(out_n, 0x55);
    p.out.data = got.data();
    v->fn(p);
    ASSERT_EQ(got, want);
  }
}

const int kEltwiseChannels[] = {1, 2, 3, 7, 8, 9, 15, 16, 17, 24, 31, 32, 33, 40, 47, 48, 49, 63, 64, 65, 70};

TEST(EltwiseVariants, MaxPoolCommonShapes) {
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> hw(3, 11);
  for (int c : kEltwiseChannels) {
    for (int rep = 0; rep < 2; ++rep) {
      PoolCase k;
      k.h = hw(rng);
      k.w = hw(rng);
      k.c = c;
      k.kh = k.kw = 2;
      k.sh = k.sw = 2;  // 2x2 s2
      check_pool(k, rng);
      k.kh = k.kw = 3;  // 3x3 s2 pad 1 (both sides)
      k.pt = k.pl = k.pb = k.pr = 1;
      check_pool(k, rng);
      k.pb = k.pr = 0;  // 3x3 s2 pad 1 top/left only
      check_pool(k, rng);
      k.sh = k.sw = 1;  // 3x3 s1 pad 1
      k.pb = k.pr = 1;
      check_pool(k, rng);
      check_pool(k, rng, /*all_min=*/true);
    }
  }
}

TEST(EltwiseVariants, MaxPoolAsymmetric) {
  std::mt19937 rng(43);
  std::uniform_int_distribution<int> hw(1, 12), ch(1, 70), kk(1, 5), ss(1, 3);
  for (int it = 0; it < 300; ++it) {
    PoolCase k;
    k.c = ch(rng);
    k.kh = kk(rng);
    k.kw = kk(rng);
    k.sh = ss(rng);
    k.sw = ss(rng);
    k.pt = int(rng() % unsigned(k.kh));
    k.pb = int(rng() % unsigned(k.kh));
    k.pl = int(rng() % unsigned(k.kw));
    k.pr = int(rng() % unsigned(k.kw));
    k.h = hw(rng);
    k.w = hw(rng);
    if (k.h + k.pt + k.pb < k.kh) k.h = k.kh;
    if (k.w + k.pl + k.pr < k.kw) k.w = k.kw;
    check_pool(k, rng, it % 17 == 0);
  }
}

TEST(EltwiseVariants, MaxPoolLargeWindows) {
  std::mt19937 rng(44);
  for (int c : {1, 16, 33, 64, 70}) {
    PoolCase k;
    k.h = 31;
    k.w = 29;
    k.c = c;
    k.kh = 31;  // global pool over h, wide window in w
    k.kw = 29;
    check_pool(k, rng);
    k.kw = 31;  // kernel 31 in both, padded in w
    k.pl = 1;
    k.pr = 1;
    check_pool(k, rng);
    k.h = 20;
    k.w = 20;
    k.kh = 7;
    k.kw = 5;
    k.sh = 3;
    k.sw = 2;
    k.pt = 6;
    k.pb = 6;
    k.pl = 4;
    k.pr = 4;
    check_pool(k, rng);
  }
}

// ------------------------------------------------------------------------------------------ avgpool

// Inputs (test::Fill): random, all -128, or all 127 (the extremes of the window sums).
using ef::test::Fill;

// Runs every avgpool variant on the case; the multipliers per window size are the loader's:
// m_n = float(ratio / n), ratio = s_in / s_out.
void check_avgpool(const PoolCase& k, std::mt19937& rng, int32_t zi, int32_t zo, double ratio,
                   Fill fill = Fill::kRandom) {
  ASSERT_GE(k.h + k.pt + k.pb, k.kh) << k.str();
  ASSERT_GE(k.w + k.pl + k.pr, k.kw) << k.str();
  const int oh = k.out_h(), ow = k.out_w();
  const std::size_t in_n = std::size_t(k.h) * k.w * k.c, out_n = std::size_t(oh) * ow * k.c;
  const std::vector<int8_t> in = ef::test::make_input(in_n, fill, rng);
  std::vector<Requant> by_count(std::size_t(k.kh) * k.kw);
  for (std::size_t n = 1; n <= by_count.size(); ++n) by_count[n - 1].multiplier = static_cast<float>(ratio / double(n));
  PoolArgs p;
  p.in = TensorI8{in.data(), k.h, k.w, k.c, zi};
  p.kernel_h = k.kh;
  p.kernel_w = k.kw;
  p.stride_h = k.sh;
  p.stride_w = k.sw;
  p.pad_top = k.pt;
  p.pad_left = k.pl;
  p.requant_by_count = by_count.data();
  std::vector<int8_t> want(out_n);
  p.out = MutTensorI8{want.data(), oh, ow, k.c, zo};
  avgpool_i8_ref(p);
  for (const PoolVariant* v : avgpool_variants()) {
    SCOPED_TRACE(std::string(v->name) + " " + k.str() + " zi " + std::to_string(zi) + " zo " + std::to_string(zo) +
                 " ratio " + std::to_string(ratio));
    std::vector<int8_t> got(out_n, 0x55);
    p.out.data = got.data();
    v->fn(p);
    ASSERT_EQ(got, want);
  }
}

TEST(EltwiseVariants, AvgPoolCommonShapes) {
  std::mt19937 rng(45);
  std::uniform_int_distribution<int> hw(3, 11), zp(-128, 127);
  for (int c : kEltwiseChannels) {
    PoolCase k;
    k.h = hw(rng);
    k.w = hw(rng);
    k.c = c;
    k.kh = k.kw = 2;
    k.sh = k.sw = 2;  // 2x2 s2
    check_avgpool(k, rng, zp(rng), zp(rng), 1.0);
    k.kh = k.kw = 3;  // 3x3 s2 pad 1: windows of 4, 6 and 9 positions
    k.pt = k.pl = k.pb = k.pr = 1;
    check_avgpool(k, rng, zp(rng), zp(rng), log_uniform(rng, -3, 3));
    k.sh = k.sw = 1;  // 3x3 s1 pad 1
    check_avgpool(k, rng, zp(rng), zp(rng), log_uniform(rng, -3, 3));
    check_avgpool(k, rng, 0, 0, 1.0, Fill::kMin);
    check_avgpool(k, rng, -128, 127, 1.0, Fill::kMax);
  }
}

TEST(EltwiseVariants, AvgPoolTiesAndSaturation) {
  std::mt19937 rng(46);
  std::uniform_int_distribution<int> zp(-128, 127);
  for (int c : {1, 5, 16, 17, 33, 64, 65}) {
    PoolCase k;
    k.h = 7;
    k.w = 9;
    k.c = c;
    k.kh = 2;  // windows of 1, 2 and 4 positions: ratio / n is a power of two, many exact halves
    k.kw = 2;
    k.pt = k.pl = k.pb = k.pr = 1;
    for (double ratio : {0.5, 1.0, 2.0, 0.25}) check_avgpool(k, rng, zp(rng), zp(rng), ratio);
    for (double ratio : {64.0, 4096.0, 1e6}) {  // every output saturates at -128 or 127
      check_avgpool(k, rng, zp(rng), zp(rng), ratio);
      check_avgpool(k, rng, -128, 127, ratio, Fill::kMax);
      check_avgpool(k, rng, 127, -128, ratio, Fill::kMin);
    }
  }
}

TEST(EltwiseVariants, AvgPoolAsymmetricAndLargeWindows) {
  std::mt19937 rng(47);
  std::uniform_int_distribution<int> hw(1, 12), ch(1, 70), kk(1, 5), ss(1, 3), zp(-128, 127);
  for (int it = 0; it < 200; ++it) {
    PoolCase k;
    k.c = ch(rng);
    k.kh = kk(rng);
    k.kw = kk(rng);
    k.sh = ss(rng);
    k.sw = ss(rng);
    k.pt = int(rng() % unsigned(k.kh));
    k.pb = int(rng() % unsigned(k.kh));
    k.pl = int(rng() % unsigned(k.kw));
    k.pr = int(rng() % unsigned(k.kw));
    k.h = hw(rng);
    k.w = hw(rng);
    if (k.h + k.pt + k.pb < k.kh) k.h = k.kh;
    if (k.w + k.pl + k.pr < k.kw) k.w = k.kw;
    check_avgpool(k, rng, zp(rng), zp(rng), log_uniform(rng, -4, 4));
  }
  for (int c : {1, 16, 33, 64, 70}) {
    PoolCase k;
    k.h = 31;
    k.w = 31;
    k.c = c;
    k.kh = 31;  // global 31 x 31 pool: sums up to 961 * 255
    k.kw = 31;
    check_avgpool(k, rng, zp(rng), zp(rng), 1.0);
    check_avgpool(k, rng, -128, 0, 1.0, Fill::kMax);
    check_avgpool(k, rng, 127, 0, 1.0, Fill::kMin);
  }
}

// -------------------------------------------------------------------------------------------- clamp

void check_clamp(std::size_t n, int32_t lo, int32_t hi, std::mt19937& rng) {
  const std::vector<int8_t> in = random_bytes(n, rng);
  ClampArgs a;
  a.in = TensorI8{in.data(), 1, 1, int(n), 0};
  a.out_min = lo;
  a.out_max = hi;
  std::vector<int8_t> want(n);
  a.out = MutTensorI8{want.data(), 1, 1, int(n), 0};
  clamp_i8_ref(a);
  for (const ClampVariant* v : clamp_variants()) {
    SCOPED_TRACE(std::string(v->name) + " n " + std::to_string(n) + " [" + std::to_string(lo) + ", " +
                 std::to_string(hi) + "]");
    std::vector<int8_t> got(n, 0x55);
    a.out.data = got.data();
    v->fn(a);
    ASSERT_EQ(got, want) << "separate output";
    std::vector<int8_t> io = in;  // in place, as the planner binds it
    ClampArgs b = a;
    b.in.data = io.data();
    b.out.data = io.data();
    v->fn(b);
    ASSERT_EQ(io, want) << "in place";
  }
}

TEST(EltwiseVariants, ClampFlatSizes) {
  std::mt19937 rng(48);
  std::uniform_int_distribution<int> q(-128, 127);
  for (std::size_t n = 0; n <= 130; ++n) {
    int lo = q(rng), hi = q(rng);
    if (lo > hi) std::swap(lo, hi);
    check_clamp(n, lo, hi, rng);
  }
  for (std::size_t n : {255u, 1001u, 4097u, 65537u}) {
    check_clamp(n, -128, 127, rng);  // no-op range
    check_clamp(n, 0, 127, rng);     // ReLU at zero point 0
    check_clamp(n, -10, 75, rng);    // ReLU6-like
    check_clamp(n, 5, 5, rng);       // one value
    check_clamp(n, -128, -128, rng);
    check_clamp(n, 127, 127, rng);
  }
}

// ------------------------------------------------------------------------------------------- concat

struct ConcatInput {
  int c = 1;
  int32_t zp = 0;
  float m = 1.0f;
};

std::string concat_str(int h, int w, const std::vector<ConcatInput>& ins, int32_t zo) {
  std::string s = std::to_string(h) + "x" + std::to_string(w) + " zo " + std::to_string(zo) + " inputs";
  for (const ConcatInput& i : ins)
    s += " [c " + std::to_string(i.c) + " zp " + std::to_string(i.zp) + " m " + std::to_string(i.m) + "]";
  return s;
}

void check_concat(int h, int w, const std::vector<ConcatInput>& ins, int32_t zo, std::mt19937& rng) {
  ASSERT_LE(ins.size(), std::size_t(kMaxConcatInputs));
  const std::size_t pixels = std::size_t(h) * w;
  std::vector<std::vector<int8_t>> data;
  ConcatArgs a;
  a.count = int(ins.size());
  int out_c = 0;
  for (std::size_t k = 0; k < ins.size(); ++k) {
    data.push_back(random_bytes(pixels * ins[k].c, rng));
    a.in[k] = TensorI8{data.back().data(), h, w, ins[k].c, ins[k].zp};
    a.rq[k].multiplier = ins[k].m;
    out_c += ins[k].c;
  }
  std::vector<int8_t> want(pixels * out_c);
  a.out = MutTensorI8{want.data(), h, w, out_c, zo};
  concat_i8_ref(a);
  for (const ConcatVariant* v : concat_variants()) {
    SCOPED_TRACE(std::string(v->name) + " " + concat_str(h, w, ins, zo));
    std::vector<int8_t> got(want.size(), 0x55);
    a.out.data = got.data();
    v->fn(a);
    ASSERT_EQ(got, want);
  }
}

TEST(EltwiseVariants, ConcatCopiesAndRequantisations) {
  std::mt19937 rng(49);
  std::uniform_int_distribution<int> zp(-128, 127), hw(1, 9);
  for (int c0 : kEltwiseChannels)
    for (int c1 : {1, 7, 16, 17, 32, 64, 65}) {
      const int h = hw(rng), w = hw(rng);
      const int32_t zo = zp(rng);
      // Both inputs in the output's quantisation: two copies.
      check_concat(h, w, {{c0, zo, 1.0f}, {c1, zo, 1.0f}}, zo, rng);
      // A copy and a requantisation.
      check_concat(h, w, {{c0, zo, 1.0f}, {c1, zp(rng), log_uniform(rng, -3, 2)}}, zo, rng);
      // Two requantisations (also m == 1 with another zero point: a shift, not a copy).
      check_concat(h, w, {{c0, zp(rng), log_uniform(rng, -3, 2)}, {c1, zp(rng), 1.0f}}, zo, rng);
    }
}

TEST(EltwiseVariants, ConcatShippedShapesAndManyInputs) {
  std::mt19937 rng(50);
  std::uniform_int_distribution<int> zp(-128, 127), ch(1, 70), hw(1, 6);
  check_concat(30, 40, {{64, 3, 1.0f}, {64, 3, 1.0f}}, 3, rng);  // the shipped network's concats
  check_concat(60, 80, {{32, -5, 1.0f}, {32, 7, 0.8125f}}, -5, rng);
  check_concat(1, 1, {{1, 0, 1.0f}}, 0, rng);  // 1 x 1 x 1
  check_concat(1, 1, {{3, 10, 0.5f}}, -10, rng);
  for (int it = 0; it < 40; ++it) {
    const int count = 1 + int(rng() % unsigned(kMaxConcatInputs));
    const int32_t zo = zp(rng);
    std::vector<ConcatInput> ins(count);
    for (ConcatInput& i : ins) {
      i.c = ch(rng);
      if (rng() % 3 == 0) {
        i.zp = zo;  // copy
      } else {
        i.zp = zp(rng);
        i.m = log_uniform(rng, -4, 3);
      }
    }
    check_concat(hw(rng), hw(rng), ins, zo, rng);
  }
}

TEST(EltwiseVariants, ConcatTiesAndSaturation) {
  std::mt19937 rng(51);
  std::uniform_int_distribution<int> zp(-128, 127);
  for (int c : {1, 4, 8, 15, 16, 31, 33, 63, 64, 65, 127}) {
    for (float m : {0.5f, 1.5f, 0.25f, 2.5f})  // exact halves: round half to even decides
      check_concat(3, 5, {{c, zp(rng), m}, {c, zp(rng), m}}, zp(rng), rng);
    for (float m : {8.0f, 300.0f, 16777215.0f})  // almost every output saturates
      check_concat(2, 3, {{c, zp(rng), m}, {c, 0, 1.0f / m}}, zp(rng), rng);
  }
}

}  // namespace
}  // namespace ef::nn
