#include "core/classes.h"

namespace ef {

namespace {
constexpr std::string_view kNames[kNumClassesWithUnknown] = {
    "unknown", "bed", "books", "ceiling", "chair", "floor", "furniture",
    "objects", "painting", "sofa", "table", "tv", "wall", "window"};

// Paper's \definecolor table, each component round(x * 255).
constexpr Rgb8 kColors[kNumClassesWithUnknown] = {
    {0, 0, 0},        // unknown
    {0, 128, 128},    // bed
    {250, 50, 50},    // books
    {102, 0, 204},    // ceiling
    {50, 50, 250},    // chair
    {230, 230, 237},  // floor
    {255, 69, 20},    // furniture
    {255, 20, 127},   // objects
    {50, 50, 150},    // painting
    {222, 180, 140},  // sofa
    {50, 250, 50},    // table
    {255, 215, 0},    // tv
    {150, 150, 150},  // wall
    {0, 255, 255},    // window
};
}  // namespace

std::string_view class_name(int id) { return id >= 0 && id < kNumClassesWithUnknown ? kNames[id] : "invalid"; }

Rgb8 class_color(int id) { return id >= 0 && id < kNumClassesWithUnknown ? kColors[id] : Rgb8{0, 0, 0}; }

}  // namespace ef
