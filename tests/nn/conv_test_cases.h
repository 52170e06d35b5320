// Layers for the conv_i8 variant tests (test_nn_conv_variants.cpp, test_conv_avxvnni.cpp): one
// case description, random tensors drawn from a seed, the ConvArgs of a layer, and the list of cases
// every variant (and every test twin) must match the reference on. Tensors live in exact-size heap
// buffers, so a read or write past them is caught by ASan in CI.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "nn/conv_kernels.h"
#include "nn/layers_ref.h"

namespace ef::nn::conv_test {

struct AlignedFree {
  void operator()(void* p) const { std::free(p); }
};
using Blob = std::unique_ptr<void, AlignedFree>;
inline Blob aligned_blob(std::size_t bytes) {
  return Blob(std::aligned_alloc(64, (bytes + 63) / 64 * 64 + 64));
}

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

inline Layer make_layer(const Case& c, std::mt19937& rng) {
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

inline ConvArgs args_of(const Layer& l, int8_t* out) {
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

inline std::string describe(const Case& c) {
  return std::to_string(c.h) + "x" + std::to_string(c.w) + "x" + std::to_string(c.cin) + " -> " +
         std::to_string(c.cout) + " k" + std::to_string(c.kh) + "x" + std::to_string(c.kw) + " s" +
         std::to_string(c.stride) + " d" + std::to_string(c.dilation) + " pad " + std::to_string(c.pad_top) + "," +
         std::to_string(c.pad_left) + "," + std::to_string(c.pad_bottom) + "," + std::to_string(c.pad_right) +
         " zp " + std::to_string(c.in_zp) + "/" + std::to_string(c.out_zp) + " range [" + std::to_string(c.out_min) +
         ", " + std::to_string(c.out_max) + "]";
}

using Variant = kernels::KernelVariant<ConvKernelPtr>;

// conv2d_i8_ref's output for `l` over rows [oy_begin, oy_end) (-1 = to the end); bytes of the other
// rows keep the sentinel 0x5A.
inline std::vector<int8_t> reference_output(const Layer& l, int oy_begin, int oy_end) {
  std::vector<int8_t> want(std::size_t(l.oh) * l.ow * l.c.cout, int8_t(0x5A));
  ConvArgs a = args_of(l, want.data());
  a.oy_begin = oy_begin; a.oy_end = oy_end;
  conv2d_i8_ref(a);
  return want;
}

// Packs and runs `v` on `l` over rows [oy_begin, oy_end) into a buffer of sentinel bytes and compares
// it, byte for byte, with `want` (reference_output of the same layer and rows): rows outside the
// range must keep their sentinels. Stops at the first differing byte (a fatal failure).
inline void expect_matches_reference(const Variant& v, const Layer& l, int oy_begin, int oy_end,
                                     const std::vector<int8_t>& want) {
  const ConvShape shape{l.c.cin, l.c.cout, l.c.kh, l.c.kw, l.c.in_zp};
  const ConvParams params{l.weights.data(), l.bias.data(), l.rq.data()};
  Blob blob = aligned_blob(v.fn->packed_bytes(shape));
  v.fn->pack(shape, params, blob.get());
  std::vector<int8_t> got(want.size(), int8_t(0x5A));
  ConvArgs a = args_of(l, got.data());
  a.packed = blob.get();
  a.oy_begin = oy_begin; a.oy_end = oy_end;
  v.fn->run(a);
  for (std::size_t i = 0; i < want.size(); ++i) {
    ASSERT_EQ(int(got[i]), int(want[i])) << v.name << " differs from conv2d_i8_ref at byte " << i << " (pixel "
                                         << i / l.c.cout << ", channel " << i % l.c.cout << ") for "
                                         << describe(l.c) << ", rows [" << oy_begin << ", " << oy_end << ")";
  }
}

// The same, against a reference computed here (callers that test several variants on one layer
// compute it once and pass it).
inline void expect_matches_reference(const Variant& v, const Layer& l, int oy_begin, int oy_end) {
  expect_matches_reference(v, l, oy_begin, oy_end, reference_output(l, oy_begin, oy_end));
}

// The cases, each family with its own seed, each through `check(layer, oy_begin, oy_end)` (rows
// [oy_begin, oy_end), -1 = to the end). A family stops at the first fatal failure.
using ConvCheck = std::function<void(const Layer&, int, int)>;

inline bool failed() { return ::testing::Test::HasFatalFailure(); }

// Channel counts around every panel width and k-group step, 3x3.
inline void conv_cases_channel_counts(const ConvCheck& check) {
  std::mt19937 rng(101);
  for (int cin : {1, 3, 4, 5, 7, 8, 9, 15, 16, 17, 24, 33})
    for (int cout : {1, 3, 4, 5, 8, 9, 14, 16, 17, 24, 31, 32, 33, 48, 64, 65, 80, 96, 130}) {
      check(make_layer(Case{5, 7, cin, cout, 3, 3, 1, 1, 1, 1, 1, 1}, rng), 0, -1);
      if (failed()) return;
    }
}

// Random sizes, kernels up to 5x5, strides and dilations up to 3, asymmetric padding, zero points.
inline void conv_cases_random_geometry(const ConvCheck& check) {
  std::mt19937 rng(202);
  std::uniform_int_distribution<int> hw(1, 19), ch(1, 40), k(1, 5), s(1, 3), d(1, 3), zp(-128, 127);
  for (int rep = 0; rep < 120; ++rep) {
    Case c{hw(rng), hw(rng), ch(rng), ch(rng), k(rng), k(rng), s(rng), d(rng), 0, 0, 0, 0};
    const int span_h = c.dilation * (c.kh - 1) + 1, span_w = c.dilation * (c.kw - 1) + 1;
    std::uniform_int_distribution<int> ph(0, span_h - 1), pw(0, span_w - 1);
    c.pad_top = ph(rng); c.pad_bottom = ph(rng); c.pad_left = pw(rng); c.pad_right = pw(rng);
    if (c.h + c.pad_top + c.pad_bottom < span_h || c.w + c.pad_left + c.pad_right < span_w) continue;
    c.in_zp = zp(rng); c.out_zp = zp(rng);
    check(make_layer(c, rng), 0, -1);
    if (failed()) return;
  }
}

// Rows longer than every tile (5..16 pixels), with tails of each length; 1x1 pointwise; channels
// that do not fill the panels (the PMADDWD tiles store full panels into the next pixels of the row,
// which are stored later; never past the row).
inline void conv_cases_wide_rows(const ConvCheck& check) {
  std::mt19937 rng(303);
  for (int w : {1, 2, 11, 12, 13, 16, 17, 29, 33, 40}) {
    check(make_layer(Case{2, w, 24, 48, 1, 1, 1, 1, 0, 0, 0, 0}, rng), 0, -1);
    check(make_layer(Case{3, w, 32, 32, 3, 3, 1, 1, 1, 1, 1, 1}, rng), 0, -1);
    check(make_layer(Case{4, w, 4, 24, 3, 3, 2, 1, 1, 1, 1, 1}, rng), 0, -1);
    check(make_layer(Case{3, w, 32, 14, 1, 1, 1, 1, 0, 0, 0, 0}, rng), 0, -1);
    check(make_layer(Case{2, w, 8, 3, 1, 1, 1, 1, 0, 0, 0, 0}, rng), 0, -1);
    if (failed()) return;
  }
}

// The PMADDWD variants pack a k x k layer whose channels are not a multiple of 8 as one tap of
// taps x cin channels when that is at most 256 values: both sides of that boundary, with padding.
inline void conv_cases_whole_window(const ConvCheck& check) {
  std::mt19937 rng(606);
  for (auto [k, cin] : {std::pair{3, 28}, {3, 29}, {5, 10}, {5, 11}, {3, 4}, {7, 5}, {2, 3}}) {
    check(make_layer(Case{9, 11, cin, 19, k, k, 1, 1, k / 2, k / 2, k / 2, k / 2}, rng), 0, -1);
    check(make_layer(Case{9, 12, cin, 24, k, k, 2, 1, k / 2, k / 2, k / 2, k / 2}, rng), 0, -1);
    if (failed()) return;
  }
}

// Row ranges; 1x1 with 14 and 3 channels: partial panels, whose stores may run into the next pixel.
inline void conv_cases_row_ranges(const ConvCheck& check) {
  std::mt19937 rng(404);
  const Layer l = make_layer(Case{9, 13, 16, 20, 3, 3, 1, 1, 1, 1, 1, 1}, rng);
  const Layer pw14 = make_layer(Case{6, 11, 32, 14, 1, 1, 1, 1, 0, 0, 0, 0}, rng);
  const Layer pw3 = make_layer(Case{5, 3, 8, 3, 1, 1, 1, 1, 0, 0, 0, 0}, rng);
  for (auto [b, e] : {std::pair{0, 1}, {3, 4}, {2, 7}, {8, 9}, {0, 9}, {5, 5}}) {
    check(l, b, e);
    check(pw14, b < 6 ? b : 5, e < 6 ? e : 6);
    check(pw3, b < 5 ? b : 4, e < 5 ? e : 5);
    if (failed()) return;
  }
}

// Huge biases and multipliers (most outputs clamp at both ends); ReLU6-like ranges with extreme zero
// points; multiplier 0.5 with tiny accumulators (every odd accumulator a rounding tie); 5x5 with
// dilation 2 on an image smaller than the window (every tap hits padding somewhere).
inline void conv_cases_saturation(const ConvCheck& check) {
  std::mt19937 rng(505);
  Case big{6, 9, 17, 19, 3, 3, 1, 1, 1, 1, 1, 1};
  big.bias_range = 1 << 30;
  big.mult_lo = 0.5f; big.mult_hi = 1000.0f;
  check(make_layer(big, rng), 0, -1);
  for (auto [zp, lo, hi] : {std::tuple{-128, -128, -80}, {127, 127, 127}, {0, 0, 37}, {-20, -20, 127}}) {
    Case c{5, 6, 12, 21, 3, 3, 1, 1, 1, 1, 1, 1};
    c.out_zp = zp; c.out_min = lo; c.out_max = hi;
    check(make_layer(c, rng), 0, -1);
  }
  Case ties{4, 5, 3, 9, 1, 1, 1, 1, 0, 0, 0, 0};
  ties.bias_range = 3;
  ties.mult_lo = ties.mult_hi = 0.5f;
  Layer l = make_layer(ties, rng);
  for (auto& v : l.weights) v = int8_t(v % 2);
  for (auto& v : l.in) v = int8_t(v % 3);
  check(l, 0, -1);
  check(make_layer(Case{3, 4, 10, 18, 5, 5, 1, 2, 4, 4, 4, 4}, rng), 0, -1);
}

// Inputs of -128 and 127 only, weights of +-127: the unsigned flip's extremes (0 and 255) in every
// product of the VNNI paths, with zero points at both ends.
inline void conv_cases_extremes(const ConvCheck& check) {
  std::mt19937 rng(707);
  for (int32_t in_zp : {-128, 127}) {
    Case c{4, 9, 13, 20, 3, 3, 1, 1, 1, 1, 1, 1};
    c.in_zp = in_zp;
    Layer l = make_layer(c, rng);
    for (auto& v : l.in) v = int8_t(v < 0 ? -128 : 127);
    for (auto& v : l.weights) v = int8_t(v < 0 ? -127 : 127);
    check(l, 0, -1);
  }
}

// The convolutions of models/deeplabv3-mnv2-nyu13.efm (issue 28): the 3-channel stride-2 stem on odd
// sizes (the 257-wide input's 129-pixel output rows included), its 1x1 layers up to 960 channels
// (151 outputs: a partial last panel), each on rows with a partial last tile, and the 1x1 layer on
// the global pool's single pixel (every tile then holds one pixel).
inline void conv_cases_deeplab(const ConvCheck& check) {
  std::mt19937 rng(808);
  check(make_layer(Case{13, 17, 3, 32, 3, 3, 2, 1, 1, 1, 1, 1}, rng), 0, -1);
  check(make_layer(Case{5, 257, 3, 32, 3, 3, 2, 1, 1, 1, 1, 1}, rng), 0, -1);
  for (auto [cin, cout] : {std::pair{32, 16}, {16, 96}, {24, 144}, {32, 192}, {64, 384}, {96, 576}, {576, 160},
                           {160, 960}, {960, 160}, {960, 320}, {320, 256}, {512, 256}, {144, 48}, {304, 256},
                           {256, 151}}) {
    check(make_layer(Case{2, 7, cin, cout, 1, 1, 1, 1, 0, 0, 0, 0}, rng), 0, -1);
    if (failed()) return;
  }
  for (auto [cin, cout] : {std::pair{320, 256}, {960, 151}, {3, 5}}) {
    check(make_layer(Case{1, 1, cin, cout, 1, 1, 1, 1, 0, 0, 0, 0}, rng), 0, -1);
    if (failed()) return;
  }
}

inline void for_each_conv_case(const ConvCheck& check) {
  for (auto family : {conv_cases_channel_counts, conv_cases_random_geometry, conv_cases_wide_rows,
                      conv_cases_whole_window, conv_cases_row_ranges, conv_cases_saturation, conv_cases_extremes,
                      conv_cases_deeplab}) {
    family(check);
    if (failed()) return;
  }
}

}  // namespace ef::nn::conv_test
