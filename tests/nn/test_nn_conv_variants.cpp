// Every conv_i8 variant this CPU (or qemu CPU) runs against the scalar reference conv2d_i8_ref, byte
// for byte: random shapes around every tile and panel size (channels 1..130, kernels 1x1 to 5x5,
// strides, dilations, asymmetric padding, odd widths), row ranges, saturating outputs, fused
// activation ranges and rounding ties. Tensors live in exact-size heap buffers, so a read or write
// past them is caught by ASan in CI.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "../kernels/kernel_test_util.h"
#include "nn/conv_kernels.h"
#include "nn/conv_test_cases.h"
#include "nn/layers_ref.h"

namespace ef::nn {
namespace {

using namespace conv_test;

// Runs every runnable variant on `l` over rows [oy_begin, oy_end) and compares with the reference
// (computed once); rows outside the range must keep their sentinel bytes.
void expect_variants_match(const Layer& l, int oy_begin = 0, int oy_end = -1) {
  const std::vector<int8_t> want = reference_output(l, oy_begin, oy_end);
  const bool failed_before = failed();  // stop at this layer's first mismatch, not an earlier one's
  for (const auto& v : kConvI8Variants) {
    if (!kernels::isa_available(v.isa, detected_cpu_features())) continue;
    expect_matches_reference(v, l, oy_begin, oy_end, want);
    if (!failed_before && failed()) return;
  }
}

TEST(NnConvVariants, ReportVariants) {
  EXPECT_FALSE(test::runnable_variants(kConvI8Variants, "conv_i8").empty());
}

// The case families of conv_test_cases.h (each described there), every runnable variant each.
TEST(NnConvVariants, ChannelCountsAroundPanelsAndSteps) { conv_cases_channel_counts([](const Layer& l, int b, int e) { expect_variants_match(l, b, e); }); }
TEST(NnConvVariants, RandomGeometry) { conv_cases_random_geometry([](const Layer& l, int b, int e) { expect_variants_match(l, b, e); }); }
TEST(NnConvVariants, WideRowsAndPointwise) { conv_cases_wide_rows([](const Layer& l, int b, int e) { expect_variants_match(l, b, e); }); }
TEST(NnConvVariants, WholeWindowPackingBoundary) { conv_cases_whole_window([](const Layer& l, int b, int e) { expect_variants_match(l, b, e); }); }
TEST(NnConvVariants, RowRangesWriteOnlyTheirRows) { conv_cases_row_ranges([](const Layer& l, int b, int e) { expect_variants_match(l, b, e); }); }
TEST(NnConvVariants, SaturationActivationRangesAndTies) { conv_cases_saturation([](const Layer& l, int b, int e) { expect_variants_match(l, b, e); }); }
TEST(NnConvVariants, ExtremeInputsAndWeights) { conv_cases_extremes([](const Layer& l, int b, int e) { expect_variants_match(l, b, e); }); }
TEST(NnConvVariants, DeepLabShapes) { conv_cases_deeplab([](const Layer& l, int b, int e) { expect_variants_match(l, b, e); }); }

}  // namespace
}  // namespace ef::nn
