// conv_i8__avxvnni (VEX VPDPBUSD on ymm, nn/conv_i8_vnni256.h) on CPUs that may lack AVX-VNNI:
//   - the variant is a row of conv_i8's table, between avx2 and avx512vnni, and dispatch takes it
//     only when the features report AVX-VNNI (and no AVX-512 VNNI, which is preferred);
//   - where the CPU lacks AVX-VNNI it is skipped with a message, never run;
//   - its EVEX twin conv_i8_vnni256_twin__avx512vnni (nn/conv_i8_twins.h: the same source, the same
//     instruction with the EVEX encoding) runs against conv2d_i8_ref byte for byte on the shapes of
//     nn/conv_test_cases.h (the cases of test_nn_conv_variants.cpp, same seeds), wherever the CPU has AVX-512 VNNI;
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
#include "nn/conv_test_cases.h"
#include "nn/layers_ref.h"

#if defined(__x86_64__)
#include "nn/conv_i8_twins.h"
#endif

namespace ef::nn {
namespace {

#if defined(__x86_64__)

using namespace conv_test;

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
