// Every add_i8 and maxpool_i8 variant the CPU can run (nn/eltwise_kernels.h, kAddI8Variants and
// kMaxPoolI8Variants) against the specifications add_i8_ref and maxpool_i8_ref, byte for byte.
// add: flat sizes 0..130 and odd large ones, random shapes, zero points, multipliers (log-uniform,
// saturating, and ma = mb = 0.5 so that half the sums are rounding ties), narrowed output ranges,
// and in-place operation (out == a, out == b). maxpool: channels 1..70 (around 8/16/32/64), 2x2 s2,
// 3x3 s2 pad 1, 3x3 s1 pad 1, asymmetric kernels / strides / pads, global windows up to 31, inputs
// full of -128. Tensors live in exact-size heap buffers, so any read or write past one is a heap
// overflow under ASan.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "kernels/kernel_test_util.h"
#include "nn/eltwise_kernels.h"

namespace ef::nn {
namespace {

using AddVariant = kernels::KernelVariant<AddI8Fn>;
using PoolVariant = kernels::KernelVariant<PoolI8Fn>;

const std::vector<const AddVariant*>& add_variants() {
  static const std::vector<const AddVariant*> v = ef::test::runnable_variants(kAddI8Variants, "add_i8");
  return v;
}
const std::vector<const PoolVariant*>& pool_variants() {
  static const std::vector<const PoolVariant*> v = ef::test::runnable_variants(kMaxPoolI8Variants, "maxpool_i8");
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

const int kChannels[] = {1, 2, 3, 7, 8, 9, 15, 16, 17, 24, 31, 32, 33, 40, 47, 48, 49, 63, 64, 65, 70};

TEST(EltwiseVariants, MaxPoolCommonShapes) {
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> hw(3, 11);
  for (int c : kChannels) {
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

}  // namespace
}  // namespace ef::nn
