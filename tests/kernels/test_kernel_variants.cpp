// The variant machinery itself: dispatch picks the best variant the features allow, and the ISA
// levels the CPU reports are the ones CI expects (EF_EXPECT_ISAS, e.g. "neon" under
// QEMU_CPU=cortex-a53 and "neon neondot" under QEMU_CPU=max), so a qemu run that silently lost a path
// fails instead of passing with fewer variants tested.
#include <gtest/gtest.h>

#include <cstdlib>
#include <set>
#include <sstream>
#include <string>

#include "kernels/depth_u16_to_metres_variants.h"
#include "kernels/dot_i8_variants.h"
#include "kernels/variants.h"
#include "platform/cpu/cpu_features.h"

namespace ef::kernels {
namespace {

const Isa kAllIsas[] = {Isa::sse41, Isa::avx2, Isa::avxvnni, Isa::avx512vnni, Isa::neon, Isa::neondot};

TEST(KernelVariants, ReportsDetectedIsasAndMatchesExpectation) {
  std::set<std::string> available;
  for (Isa isa : kAllIsas)
    if (isa_available(isa, detected_cpu_features())) available.insert(isa_name(isa));
  std::string have;
  for (const auto& s : available) have += (have.empty() ? "" : " ") + s;
  std::printf("[ variants ] detected ISA levels: %s (EF_ISA-capped: %s)\n", have.c_str(),
              cpu_features().describe().c_str());
  std::printf("[ variants ] dispatch: depth_u16_to_metres -> %s, dot_i8 -> %s\n", depth_u16_to_metres_selected(),
              dot_i8_selected());

  const char* expect = std::getenv("EF_EXPECT_ISAS");
  if (!expect || !*expect) GTEST_SKIP() << "EF_EXPECT_ISAS not set; detected: " << have;
  std::set<std::string> want;
  std::istringstream in(expect);
  for (std::string w; in >> w;) want.insert(w);
  EXPECT_EQ(want, available) << "EF_EXPECT_ISAS=\"" << expect << "\" but the CPU reports \"" << have << "\"";
}

TEST(KernelVariants, ScalarRowFirstAndAlwaysAvailable) {
  EXPECT_EQ(kDotI8Variants[0].isa, Isa::scalar);
  EXPECT_EQ(kDepthU16ToMetresVariants[0].isa, Isa::scalar);
  EXPECT_TRUE(isa_available(Isa::scalar, CpuFeatures{}));
}

TEST(KernelVariants, BestVariantFollowsFeatures) {
  // No features at all: the reference.
  EXPECT_STREQ(best_variant(kDotI8Variants, CpuFeatures{}).name, "dot_i8_ref");
  // Every feature: the last row of the table.
  CpuFeatures all;
  all.sse41 = all.avx2 = all.avxvnni = all.avx512vnni = all.neon = all.neondot = true;
  constexpr std::size_t kDot = sizeof(kDotI8Variants) / sizeof(kDotI8Variants[0]);
  EXPECT_STREQ(best_variant(kDotI8Variants, all).name, kDotI8Variants[kDot - 1].name);
  // Capping with the EF_ISA rules lowers the choice to that level.
  CpuFeatures capped = all;
#if defined(__x86_64__)
  ASSERT_TRUE(cap_cpu_features(capped, "avx2"));
  EXPECT_STREQ(best_variant(kDotI8Variants, capped).name, "dot_i8__avx2");
#elif defined(__aarch64__)
  ASSERT_TRUE(cap_cpu_features(capped, "neon"));
  EXPECT_STREQ(best_variant(kDotI8Variants, capped).name, "dot_i8__neon");
#endif
  ASSERT_TRUE(cap_cpu_features(capped, "scalar"));
  EXPECT_STREQ(best_variant(kDotI8Variants, capped).name, "dot_i8_ref");
}

TEST(KernelVariants, DispatchUsesTheBestAvailable) {
  EXPECT_STREQ(dot_i8_selected(), best_variant(kDotI8Variants, cpu_features()).name);
  EXPECT_STREQ(depth_u16_to_metres_selected(), best_variant(kDepthU16ToMetresVariants, cpu_features()).name);
}

}  // namespace
}  // namespace ef::kernels
