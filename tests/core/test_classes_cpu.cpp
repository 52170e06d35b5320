#include <gtest/gtest.h>

#include <set>
#include <string>

#include "core/classes.h"
#include "platform/cpu_features.h"

namespace ef {
namespace {

TEST(Classes, FourteenNamesInIdOrder) {
  EXPECT_EQ(kNumClasses, 13);
  EXPECT_EQ(kNumClassesWithUnknown, 14);
  const char* expected[] = {"unknown", "bed",      "books", "ceiling", "chair", "floor", "furniture",
                            "objects", "painting", "sofa",  "table",   "tv",    "wall",  "window"};
  std::set<std::string> distinct;
  for (int id = 0; id < kNumClassesWithUnknown; ++id) {
    EXPECT_EQ(class_name(id), expected[id]) << "id " << id;
    distinct.insert(std::string(class_name(id)));
  }
  EXPECT_EQ(distinct.size(), 14u);
  EXPECT_EQ(class_name(kFurniture), "furniture");
  EXPECT_EQ(class_name(kWindow), "window");
  EXPECT_EQ(class_name(14), "invalid");
  EXPECT_EQ(class_name(-1), "invalid");
  EXPECT_EQ(class_name(255), "invalid");
}

// Values from the \definecolor table of the SemanticFusion paper, each component round(x * 255):
//   bedColor   0.0,0.501960784314,0.501960784314   -> 0,128,128
//   floorColor 0.9,0.9,0.93                         -> 229.5 rounds to 230; 237.15 -> 237
//   furnColor  1.0,0.270588235294,0.078431372549    -> 255,69,20
//   objsColor  1.0,0.078431372549,0.498039215686    -> 255,20,127
//   sofaColor  0.870588235294,0.705882352941,0.549019607843 -> 222,180,140
//   tvColor    1.0,0.843137254902,0.0               -> 255,215,0
//   ceilColor  0.4,0.0,0.8                          -> 102,0,204
//   windColor  0.0,1.0,1.0                          -> 0,255,255
TEST(Classes, PaletteMatchesThePaper) {
  EXPECT_EQ(class_color(kUnknown), (Rgb8{0, 0, 0}));
  EXPECT_EQ(class_color(kBed), (Rgb8{0, 128, 128}));
  EXPECT_EQ(class_color(kCeiling), (Rgb8{102, 0, 204}));
  EXPECT_EQ(class_color(kFloor), (Rgb8{230, 230, 237}));
  EXPECT_EQ(class_color(kFurniture), (Rgb8{255, 69, 20}));
  EXPECT_EQ(class_color(kObjects), (Rgb8{255, 20, 127}));
  EXPECT_EQ(class_color(kSofa), (Rgb8{222, 180, 140}));
  EXPECT_EQ(class_color(kTv), (Rgb8{255, 215, 0}));
  EXPECT_EQ(class_color(kWindow), (Rgb8{0, 255, 255}));
  EXPECT_EQ(class_color(99), (Rgb8{0, 0, 0}));
  // Every class has its own colour.
  std::set<int> colors;
  for (int id = 0; id < kNumClassesWithUnknown; ++id) {
    const Rgb8 c = class_color(id);
    colors.insert(c.r << 16 | c.g << 8 | c.b);
  }
  EXPECT_EQ(colors.size(), 14u);
}

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
