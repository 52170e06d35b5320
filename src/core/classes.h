// The 13 NYUv2 classes of Couprie et al., as used by SemanticFusion, and the paper's colour palette.
// Class ids: 0 = unknown, 1..13 in alphabetical order.
#pragma once

#include <cstdint>
#include <string_view>

#include "core/image.h"

namespace ef {

enum ClassId : uint8_t {
  kUnknown = 0,
  kBed = 1,
  kBooks = 2,
  kCeiling = 3,
  kChair = 4,
  kFloor = 5,
  kFurniture = 6,
  kObjects = 7,
  kPainting = 8,
  kSofa = 9,
  kTable = 10,
  kTv = 11,
  kWall = 12,
  kWindow = 13,
};

constexpr int kNumClasses = 13;             // classes 1..13, not counting unknown
constexpr int kNumClassesWithUnknown = 14;  // ids 0..13

// Lower-case class name ("unknown", "bed", ..., "window"); "invalid" for ids above 13.
std::string_view class_name(int id);

// The paper's palette (the colour table at the top of semanticfusion-paper.tex); unknown is black.
Rgb8 class_color(int id);

}  // namespace ef
