// CPU feature detection and the EF_ISA cap (platform/cpu/cpu_features.h).
#include <gtest/gtest.h>

#include <string>

#include "platform/cpu/cpu_features.h"

namespace ef {
namespace {

CpuFeatures all_features() {
  CpuFeatures f;
  f.sse41 = f.avx2 = f.avxvnni = f.avx512vnni = true;
  f.neon = f.neondot = true;
  return f;
}

bool same(const CpuFeatures& a, const CpuFeatures& b) {
  return a.sse41 == b.sse41 && a.avx2 == b.avx2 && a.avxvnni == b.avxvnni && a.avx512vnni == b.avx512vnni &&
         a.neon == b.neon && a.neondot == b.neondot;
}

TEST(CpuFeatures, CapScalarClearsEverything) {
  CpuFeatures f = all_features();
  ASSERT_TRUE(cap_cpu_features(f, "scalar"));
  EXPECT_TRUE(same(f, CpuFeatures{}));
  EXPECT_EQ(f.describe(), "scalar");
}

TEST(CpuFeatures, CapX86Levels) {
  CpuFeatures f = all_features();
  ASSERT_TRUE(cap_cpu_features(f, "avx2"));
  EXPECT_TRUE(f.sse41);
  EXPECT_TRUE(f.avx2);
  EXPECT_FALSE(f.avxvnni);
  EXPECT_FALSE(f.avx512vnni);

  f = all_features();
  ASSERT_TRUE(cap_cpu_features(f, "sse41"));
  EXPECT_TRUE(f.sse41);
  EXPECT_FALSE(f.avx2);
  EXPECT_FALSE(f.avxvnni);
  EXPECT_FALSE(f.avx512vnni);

  f = all_features();
  ASSERT_TRUE(cap_cpu_features(f, "avxvnni"));
  EXPECT_TRUE(f.avx2);
  EXPECT_TRUE(f.avxvnni);
  EXPECT_FALSE(f.avx512vnni);

  f = all_features();
  ASSERT_TRUE(cap_cpu_features(f, "avx512vnni"));
  EXPECT_TRUE(f.avx512vnni);
  EXPECT_TRUE(f.avxvnni);
}

TEST(CpuFeatures, CapArmLevels) {
  CpuFeatures f = all_features();
  ASSERT_TRUE(cap_cpu_features(f, "neon"));
  EXPECT_TRUE(f.neon);
  EXPECT_FALSE(f.neondot);
  f = all_features();
  ASSERT_TRUE(cap_cpu_features(f, "neondot"));
  EXPECT_TRUE(f.neon);
  EXPECT_TRUE(f.neondot);
}

TEST(CpuFeatures, CapOfTheOtherArchitectureLeavesOnlyScalar) {
  // "At most NEON" on an x86 CPU (or "at most AVX2" on an ARM one) must not leave the other
  // architecture's SIMD enabled: nothing at or below the named level is available but scalar.
  CpuFeatures x86;
  x86.sse41 = x86.avx2 = x86.avxvnni = true;
  ASSERT_TRUE(cap_cpu_features(x86, "neon"));
  EXPECT_TRUE(same(x86, CpuFeatures{})) << x86.describe();
  CpuFeatures arm;
  arm.neon = arm.neondot = true;
  ASSERT_TRUE(cap_cpu_features(arm, "avx2"));
  EXPECT_TRUE(same(arm, CpuFeatures{})) << arm.describe();
}

TEST(CpuFeatures, CapNeverEnablesAndRejectsUnknownNames) {
  CpuFeatures none;
  for (const char* isa : {"scalar", "sse41", "avx2", "avxvnni", "avx512vnni", "neon", "neondot"}) {
    CpuFeatures f = none;
    EXPECT_TRUE(cap_cpu_features(f, isa)) << isa;
    EXPECT_TRUE(same(f, none)) << isa;
  }
  CpuFeatures sse_only;
  sse_only.sse41 = true;
  ASSERT_TRUE(cap_cpu_features(sse_only, "avx512vnni"));
  EXPECT_TRUE(sse_only.sse41);
  EXPECT_FALSE(sse_only.avx2);

  for (const char* bad : {"", "AVX2", "avx", "sve", "avx2 ", "native"}) {
    CpuFeatures f = all_features();
    EXPECT_FALSE(cap_cpu_features(f, bad)) << "'" << bad << "'";
    EXPECT_TRUE(same(f, all_features())) << "an unknown name must leave the features alone: '" << bad << "'";
  }
}

TEST(CpuFeatures, DescribeListsBestFirstAndAlwaysScalar) {
  EXPECT_EQ(CpuFeatures{}.describe(), "scalar");
  CpuFeatures f;
  f.sse41 = f.avx2 = true;
  EXPECT_EQ(f.describe(), "avx2 sse41 scalar");
  f = CpuFeatures{};
  f.neon = f.neondot = true;
  EXPECT_EQ(f.describe(), "neondot neon scalar");
  const std::string detected = detected_cpu_features().describe();
  EXPECT_NE(detected.find("scalar"), std::string::npos) << detected;
  EXPECT_NE(cpu_features().describe().find("scalar"), std::string::npos);
}

TEST(CpuFeatures, DetectionIsPlausible) {
  const CpuFeatures& d = detected_cpu_features();
  // Implications the detector promises.
  EXPECT_TRUE(d.avx2 || !(d.avx512vnni || d.avxvnni));
  EXPECT_TRUE(d.sse41 || !d.avx2);
  EXPECT_TRUE(d.neon || !d.neondot);
  EXPECT_FALSE((d.sse41 || d.avx2) && (d.neon || d.neondot)) << "features of two architectures";
#if defined(__x86_64__)
  EXPECT_TRUE(d.sse41) << "SSE4.1 is the x86-64 build baseline";
#elif defined(__aarch64__)
  EXPECT_TRUE(d.neon);
#endif
  // The capped set is a subset of the detected one.
  const CpuFeatures& c = cpu_features();
  EXPECT_TRUE(!c.sse41 || d.sse41);
  EXPECT_TRUE(!c.avx2 || d.avx2);
  EXPECT_TRUE(!c.avxvnni || d.avxvnni);
  EXPECT_TRUE(!c.avx512vnni || d.avx512vnni);
  EXPECT_TRUE(!c.neon || d.neon);
  EXPECT_TRUE(!c.neondot || d.neondot);
  EXPECT_EQ(&detected_cpu_features(), &d) << "detection runs once";
}

}  // namespace
}  // namespace ef
