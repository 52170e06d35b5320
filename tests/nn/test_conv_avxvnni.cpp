// conv_i8__avxvnni (VEX VPDPBUSD on ymm, nn/conv_i8_vnni256.h) on CPUs that may lack AVX-VNNI:
//   - the variant is a row of conv_i8's table, between avx2 and avx512vnni, and dispatch takes it
//     only when the features report AVX-VNNI (and no AVX-512 VNNI, which is preferred);
//   - where the CPU lacks AVX-VNNI it is skipped with a message, never run;
//   - its EVEX twin conv_i8_vnni256_twin__avx512vnni (nn/conv_i8_twins.h: the same source, the same
//     instruction with the EVEX encoding) runs against conv2d_i8_ref byte for byte on the shapes of
//     test_nn_conv_variants.cpp (same cases, same seeds), wherever the CPU has AVX-512 VNNI;
//   - where the CPU has AVX-VNNI, the variant itself runs on those shapes too.
// Tensors live in exact-size heap buffers, so a read or write past them is caught by ASan in CI.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "../kernels/kernel_test_util.h"
#include "nn/conv_kernels.h"
#include "nn/layers_ref.h"

#if defined(__x86_64__)
#include "nn/conv_i8_twins.h"
#endif

namespace ef::nn {
namespace {

#if defined(__x86_64__)

using Variant = kernels::KernelVariant<ConvKernelPtr>;

struct AlignedFree {
  void operator()(void* p) const { std::free(p); }
};
using Blob = std::unique_ptr<void, AlignedFree>;
Blob aligned_blob(std::size_t bytes) { return Blob(std::aligned_alloc(64, (bytes + 63) / 64 * 64 + 64)); }

// The layer description of test_nn_conv_variants.cpp, so the cases below draw the same tensors.
struct Case {
  int h, w, cin, cout, kh, kw, stride, dilation, pad_top, pad_left, pad_bottom, pad_right;
  int32_t in_zp = -3, out_zp = 5, out_min = -128, out_max = 127;
  int bias_range = 3000;
  float mult_lo = 0.0005f, mult_hi = 0.004f;
};

struct Layer {
  Case c;
  int oh, ow;
  std::vector<int8_t> in, weights;
  std::vector<int32_t> bias;
  std::vector<Requant> rq;
};

Layer make_layer(const Case& c, std::mt19937& rng) {
  Layer l{c, 0, 0, {}, {}, {}, {}};
  l.oh = (c.h + c.pad_top + c.pad_bottom - (c.dilation * (c.kh - 1) + 1)) / c.stride + 1;
  l.ow = (c.w + c.pad_left + c.pad_right - (c.dilation * (c.kw - 1) + 1)) / c.stride + 1;
  std::uniform_int_distribution<int> byte(-128, 127), wbyte(-127, 127), b(-c.bias_range, c.bias_range);
  std::uniform_real_distribution<float> m(c.mult_lo, c.mult_hi);
  l.in.resize(std::size_t(c.h) * c.w * c.cin);
  for (auto& v : l.in) v = int8_t(byte(rng));
  l.weights.resize(std::size_t(c.cout) * c.kh * c.kw * c.cin);
  for (auto& v : l.weights) v = int8_t(wbyte(rng));
  l.bias.resize(c.cout);
  for (auto& v : l.bias) v = b(rng);
  l.rq.resize(c.cout);
  for (auto& r : l.rq) r.multiplier = m(rng);
  return l;
}

ConvArgs args_of(const Layer& l, int8_t* out) {
  ConvArgs a;
  a.in = {l.in.data(), l.c.h, l.c.w, l.c.cin, l.c.in_zp};
  a.out = {out, l.oh, l.ow, l.c.cout, l.c.out_zp};
  a.kernel_h = l.c.kh; a.kernel_w = l.c.kw;
  a.stride_h = a.stride_w = l.c.stride;
  a.dilation_h = a.dilation_w = l.c.dilation;
  a.pad_top = l.c.pad_top; a.pad_left = l.c.pad_left;
  a.weights = l.weights.data(); a.bias = l.bias.data(); a.requant = l.rq.data();
  a.out_min = l.c.out_min; a.out_max = l.c.out_max;
  return a;
}

std::string describe(const Case& c) {
  return std::to_string(c.h) + "x" + std::to_string(c.w) + "x" + std::to_string(c.cin) + " -> " +
         std::to_string(c.cout) + " k" + std::to_string(c.kh) + "x" + std::to_string(c.kw) + " s" +
         std::to_string(c.stride) + " d" + std::to_string(c.dilation) + " pad " + std::to_string(c.pad_top) + "," +
         std::to_string(c.pad_left) + "," + std::to_string(c.pad_bottom) + "," + std::to_string(c.pad_right) +
         " zp " + std::to_string(c.in_zp) + "/" + std::to_string(c.out_zp) + " range [" + std::to_string(c.out_min) +
         ", " + std::to_string(c.out_max) + "]";
}

// Runs `v` on `l` over rows [oy_begin, oy_end) and compares with the reference; rows outside the
// range must keep their sentinel bytes.
void expect_matches_reference(const Variant& v, const Layer& l, int oy_begin = 0, int oy_end = -1) {
  const std::size_t out_bytes = std::size_t(l.oh) * l.ow * l.c.cout;
  std::vector<int8_t> want(out_bytes, int8_t(0x5A));
  ConvArgs ra = args_of(l, want.data());
  ra.oy_begin = oy_begin; ra.oy_end = oy_end;
  conv2d_i8_ref(ra);
  const ConvShape shape{l.c.cin, l.c.cout, l.c.kh, l.c.kw, l.c.in_zp};
  const ConvParams params{l.weights.data(), l.bias.data(), l.rq.data()};
  Blob blob = aligned_blob(v.fn->packed_bytes(shape));
  v.fn->pack(shape, params, blob.get());
  std::vector<int8_t> got(out_bytes, int8_t(0x5A));
  ConvArgs a = args_of(l, got.data());
  a.packed = blob.get();
  a.oy_begin = oy_begin; a.oy_end = oy_end;
  v.fn->run(a);
  for (std::size_t i = 0; i < out_bytes; ++i) {
    ASSERT_EQ(int(got[i]), int(want[i])) << v.name << " differs from conv2d_i8_ref at byte " << i << " (pixel "
                                         << i / l.c.cout << ", channel " << i % l.c.cout << ") for "
                                         << describe(l.c) << ", rows [" << oy_begin << ", " << oy_end << ")";
  }
}

// Every case of test_nn_conv_variants.cpp, with its seeds, through `check(layer, oy_begin, oy_end)`;
// stops at the first fatal failure.
void for_each_conv_case(const std::function<void(const Layer&, int, int)>& check) {
  auto run = [&](const Layer& l, int b = 0, int e = -1) {
    if (!::testing::Test::HasFatalFailure()) check(l, b, e);
  };
  {  // ChannelCountsAroundPanelsAndSteps
    std::mt19937 rng(101);
    for (int cin : {1, 3, 4, 5, 7, 8, 9, 15, 16, 17, 24, 33})
      for (int cout : {1, 3, 4, 5, 8, 9, 14, 16, 17, 24, 31, 32, 33, 48, 64, 65, 80, 96, 130})
        run(make_layer(Case{5, 7, cin, cout, 3, 3, 1, 1, 1, 1, 1, 1}, rng));
  }
  {  // RandomGeometry
    std::mt19937 rng(202);
    std::uniform_int_distribution<int> hw(1, 19), ch(1, 40), k(1, 5), s(1, 3), d(1, 3), zp(-128, 127);
    for (int rep = 0; rep < 120; ++rep) {
      Case c{hw(rng), hw(rng), ch(rng), ch(rng), k(rng), k(rng), s(rng), d(rng), 0, 0, 0, 0};
      const int span_h = c.dilation * (c.kh - 1) + 1, span_w = c.dilation * (c.kw - 1) + 1;
      std::uniform_int_distribution<int> ph(0, span_h - 1), pw(0, span_w - 1);
      c.pad_top = ph(rng); c.pad_bottom = ph(rng); c.pad_left = pw(rng); c.pad_right = pw(rng);
      if (c.h + c.pad_top + c.pad_bottom < span_h || c.w + c.pad_left + c.pad_right < span_w) continue;
      c.in_zp = zp(rng); c.out_zp = zp(rng);
      run(make_layer(c, rng));
    }
  }
  {  // WideRowsAndPointwise
    std::mt19937 rng(303);
    for (int w : {1, 2, 11, 12, 13, 16, 17, 29, 33, 40}) {
      run(make_layer(Case{2, w, 24, 48, 1, 1, 1, 1, 0, 0, 0, 0}, rng));
      run(make_layer(Case{3, w, 32, 32, 3, 3, 1, 1, 1, 1, 1, 1}, rng));
      run(make_layer(Case{4, w, 4, 24, 3, 3, 2, 1, 1, 1, 1, 1}, rng));
      run(make_layer(Case{3, w, 32, 14, 1, 1, 1, 1, 0, 0, 0, 0}, rng));
      run(make_layer(Case{2, w, 8, 3, 1, 1, 1, 1, 0, 0, 0, 0}, rng));
    }
  }
  {  // WholeWindowPackingBoundary
    std::mt19937 rng(606);
    for (auto [k, cin] : {std::pair{3, 28}, {3, 29}, {5, 10}, {5, 11}, {3, 4}, {7, 5}, {2, 3}}) {
      run(make_layer(Case{9, 11, cin, 19, k, k, 1, 1, k / 2, k / 2, k / 2, k / 2}, rng));
      run(make_layer(Case{9, 12, cin, 24, k, k, 2, 1, k / 2, k / 2, k / 2, k / 2}, rng));
    }
  }
  {  // RowRangesWriteOnlyTheirRows
    std::mt19937 rng(404);
    const Layer l = make_layer(Case{9, 13, 16, 20, 3, 3, 1, 1, 1, 1, 1, 1}, rng);
    const Layer pw14 = make_layer(Case{6, 11, 32, 14, 1, 1, 1, 1, 0, 0, 0, 0}, rng);
    const Layer pw3 = make_layer(Case{5, 3, 8, 3, 1, 1, 1, 1, 0, 0, 0, 0}, rng);
    for (auto [b, e] : {std::pair{0, 1}, {3, 4}, {2, 7}, {8, 9}, {0, 9}, {5, 5}}) {
      run(l, b, e);
      run(pw14, b < 6 ? b : 5, e < 6 ? e : 6);
      run(pw3, b < 5 ? b : 4, e < 5 ? e : 5);
    }
  }
  {  // SaturationActivationRangesAndTies
    std::mt19937 rng(505);
    Case big{6, 9, 17, 19, 3, 3, 1, 1, 1, 1, 1, 1};
    big.bias_range = 1 << 30;
    big.mult_lo = 0.5f; big.mult_hi = 1000.0f;
    run(make_layer(big, rng));
    for (auto [zp, lo, hi] : {std::tuple{-128, -128, -80}, {127, 127, 127}, {0, 0, 37}, {-20, -20, 127}}) {
      Case c{5, 6, 12, 21, 3, 3, 1, 1, 1, 1, 1, 1};
      c.out_zp = zp; c.out_min = lo; c.out_max = hi;
      run(make_layer(c, rng));
    }
    Case ties{4, 5, 3, 9, 1, 1, 1, 1, 0, 0, 0, 0};
    ties.bias_range = 3;
    ties.mult_lo = ties.mult_hi = 0.5f;
    Layer l = make_layer(ties, rng);
    for (auto& v : l.weights) v = int8_t(v % 2);
    for (auto& v : l.in) v = int8_t(v % 3);
    run(l);
    run(make_layer(Case{3, 4, 10, 18, 5, 5, 1, 2, 4, 4, 4, 4}, rng));
  }
  {  // Inputs of -128 and 127 only, weights of +-127: the unsigned flip's extremes (0 and 255) in
     // every product, with zero points at both ends.
    std::mt19937 rng(707);
    for (int32_t in_zp : {-128, 127}) {
      Case c{4, 9, 13, 20, 3, 3, 1, 1, 1, 1, 1, 1};
      c.in_zp = in_zp;
      Layer l = make_layer(c, rng);
      for (auto& v : l.in) v = int8_t(v < 0 ? -128 : 127);
      for (auto& v : l.weights) v = int8_t(v < 0 ? -127 : 127);
      run(l);
    }
  }
}

const Variant* find_row(const char* name) {
  for (const auto& v : kConvI8Variants)
    if (std::strcmp(v.name, name) == 0) return &v;
  return nullptr;
}

TEST(NnConvAvxVnni, ListedBetweenAvx2AndAvx512Vnni) {
  const Variant* row = find_row("conv_i8__avxvnni");
  ASSERT_NE(row, nullptr) << "conv_i8__avxvnni is missing from kConvI8Variants (nn/conv_i8.inc)";
  EXPECT_EQ(row->isa, kernels::Isa::avxvnni);
  const Variant* avx2 = find_row("conv_i8__avx2");
  const Variant* avx512 = find_row("conv_i8__avx512vnni");
  ASSERT_NE(avx2, nullptr);
  ASSERT_NE(avx512, nullptr);
  EXPECT_LT(avx2, row);  // tables go lowest ISA first: the last available row wins
  EXPECT_LT(row, avx512);
}

TEST(NnConvAvxVnni, DispatchTakesItOnlyWithTheFeature) {
  CpuFeatures f;
  f.sse41 = f.avx2 = true;
  EXPECT_STREQ(kernels::best_variant(kConvI8Variants, f).name, "conv_i8__avx2");
  f.avxvnni = true;
  EXPECT_STREQ(kernels::best_variant(kConvI8Variants, f).name, "conv_i8__avxvnni");
  f.avx512vnni = true;
  EXPECT_STREQ(kernels::best_variant(kConvI8Variants, f).name, "conv_i8__avx512vnni");
  f.avxvnni = false;
  EXPECT_STREQ(kernels::best_variant(kConvI8Variants, f).name, "conv_i8__avx512vnni");
  // EF_ISA=avx2 caps AVX-VNNI off; EF_ISA=avxvnni keeps it and drops AVX-512.
  CpuFeatures capped{};
  capped.sse41 = capped.avx2 = capped.avxvnni = capped.avx512vnni = true;
  ASSERT_TRUE(cap_cpu_features(capped, "avx2"));
  EXPECT_STREQ(kernels::best_variant(kConvI8Variants, capped).name, "conv_i8__avx2");
  capped.avxvnni = capped.avx512vnni = true;
  ASSERT_TRUE(cap_cpu_features(capped, "avxvnni"));
  EXPECT_STREQ(kernels::best_variant(kConvI8Variants, capped).name, "conv_i8__avxvnni");
}

TEST(NnConvAvxVnni, VariantOnShapesOfTheVariantTests) {
  const Variant* row = find_row("conv_i8__avxvnni");
  ASSERT_NE(row, nullptr);
  const auto runnable = test::runnable_variants(kConvI8Variants, "conv_i8");
  bool listed_runnable = false;
  for (const Variant* v : runnable) listed_runnable |= v == row;
  if (!detected_cpu_features().avxvnni) {
    EXPECT_FALSE(listed_runnable) << "the variant tests would run conv_i8__avxvnni on a CPU without AVX-VNNI";
    std::printf("[ variants ] conv_i8__avxvnni: not run, the CPU lacks AVX-VNNI (%s)%s\n",
                detected_cpu_features().describe().c_str(),
                detected_cpu_features().avx512vnni ? "; its EVEX twin runs in NnConvAvxVnni.TwinMatchesReference" : "");
    std::fflush(stdout);
    GTEST_SKIP() << "CPU lacks AVX-VNNI: conv_i8__avxvnni not run";
  }
  EXPECT_TRUE(listed_runnable);
  for_each_conv_case([&](const Layer& l, int b, int e) { expect_matches_reference(*row, l, b, e); });
}

TEST(NnConvAvxVnni, TwinMatchesReference) {
  for (const ConvTwin& t : kConvI8Twins) {
    if (!kernels::isa_available(t.twin.isa, detected_cpu_features())) {
      std::printf("[ variants ] %s (twin of %s): not run, the CPU lacks %s\n", t.twin.name, t.twin_of,
                  kernels::isa_name(t.twin.isa));
      std::fflush(stdout);
      continue;
    }
    std::printf("[ variants ] %s (twin of %s): ran\n", t.twin.name, t.twin_of);
    std::fflush(stdout);
    for_each_conv_case([&](const Layer& l, int b, int e) { expect_matches_reference(t.twin, l, b, e); });
    if (HasFatalFailure()) return;
  }
}

// A twin shares its variant's layout: the same packed bytes (pack runs on every CPU).
TEST(NnConvAvxVnni, TwinPacksAsTheVariant) {
  std::mt19937 rng(808);
  for (const ConvTwin& t : kConvI8Twins) {
    const Variant* row = find_row(t.twin_of);
    ASSERT_NE(row, nullptr) << t.twin_of;
    for (const Case& c : {Case{3, 3, 5, 19, 3, 3, 1, 1, 1, 1, 1, 1}, Case{2, 2, 32, 8, 1, 1, 1, 1, 0, 0, 0, 0}}) {
      const Layer l = make_layer(c, rng);
      const ConvShape shape{c.cin, c.cout, c.kh, c.kw, c.in_zp};
      const ConvParams params{l.weights.data(), l.bias.data(), l.rq.data()};
      const std::size_t bytes = row->fn->packed_bytes(shape);
      ASSERT_EQ(t.twin.fn->packed_bytes(shape), bytes) << t.twin.name;
      Blob a = aligned_blob(bytes), b = aligned_blob(bytes);
      row->fn->pack(shape, params, a.get());
      t.twin.fn->pack(shape, params, b.get());
      EXPECT_EQ(std::memcmp(a.get(), b.get(), bytes), 0) << t.twin.name << " packs differently from " << t.twin_of;
    }
  }
}

#endif  // __x86_64__

}  // namespace
}  // namespace ef::nn
