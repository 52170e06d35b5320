#include <gtest/gtest.h>

#include <set>
#include <string>

#include "core/classes.h"

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

}  // namespace
}  // namespace ef
