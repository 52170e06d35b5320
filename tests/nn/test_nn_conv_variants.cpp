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

// Runs every runnable variant on `l` over rows [oy_begin, oy_end) and compares with the reference;
// rows outside the range must keep their sentinel bytes.
void expect_variants_match(const Layer& l, int oy_begin = 0, int oy_end = -1) {
  const std::size_t out_bytes = std::size_t(l.oh) * l.ow * l.c.cout;
  std::vector<int8_t> want(out_bytes, int8_t(0x5A));
  ConvArgs ra = args_of(l, want.data());
  ra.oy_begin = oy_begin; ra.oy_end = oy_end;
  conv2d_i8_ref(ra);
  const ConvShape shape{l.c.cin, l.c.cout, l.c.kh, l.c.kw, l.c.in_zp};
  const ConvParams params{l.weights.data(), l.bias.data(), l.rq.data()};
  for (const auto& v : kConvI8Variants) {
    if (!kernels::isa_available(v.isa, detected_cpu_features())) continue;
    const std::size_t bytes = v.fn->packed_bytes(shape);
    Blob blob = aligned_blob(bytes);
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

}  // namespace
}  // namespace ef::nn
