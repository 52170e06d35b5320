// pyramid_row: the reference follows its contract (against a double-precision evaluation of the rule
// written here from kernels/pyramid_row.h: plane, step, slope, hole, intensity only from pixels with
// depth), and every variant the CPU can run writes the same row as the reference, bit for bit (row
// lengths with every overlap of the last step, invalid, negative and NaN depths, depth steps), and
// nothing outside its range.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "kernel_test_util.h"
#include "kernels/pyramid_row.h"
#include "kernels/pyramid_row_variants.h"

namespace ef::kernels {
namespace {

constexpr float kThr = 0.09f;  // the pyramid's threshold default, metres

// Four finer rows of `fw` pixels (depth and intensity) around one coarse row.
struct FinerRows {
  int fw;
  std::vector<float> depth[4], intensity[4];
  explicit FinerRows(int fw_) : fw(fw_) {
    for (int j = 0; j < 4; ++j) {
      depth[j].assign(fw, 0.0f);
      intensity[j].assign(fw, 0.0f);
    }
  }
  PyramidRow params(bool with_intensity) const {
    PyramidRow r;
    for (int j = 0; j < 4; ++j) {
      r.depth[j] = depth[j].data();
      r.intensity[j] = with_intensity ? intensity[j].data() : nullptr;
    }
    r.threshold_m = kThr;
    return r;
  }
};

// The rule in double precision, written from the contract.
void pyramid_rule(const FinerRows& w, int x, double* depth, double* intensity) {
  const double t[4] = {1, 3, 3, 1};
  const auto d = [&](int j, int i) { return static_cast<double>(w.depth[j][2 * x - 1 + i]); };
  double nearest = INFINITY;
  for (int j = 1; j <= 2; ++j)
    for (int i = 1; i <= 2; ++i)
      if (d(j, i) > 0) nearest = std::min(nearest, d(j, i));
  *depth = *intensity = 0;
  if (std::isinf(nearest)) return;
  double rs = 0, rn = 0;
  for (int j = 1; j <= 2; ++j)
    for (int i = 1; i <= 2; ++i)
      if (d(j, i) > 0 && d(j, i) <= nearest + kThr) {
        rs += d(j, i);
        rn += 1;
      }
  const double ref = rs / rn;
  double s = 0, wt = 0, gs = 0, gw = 0;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) {
      if (!(d(j, i) > 0)) continue;
      gs += t[i] * t[j] * w.intensity[j][2 * x - 1 + i];
      gw += t[i] * t[j];
      if (std::fabs(d(j, i) - ref) > kThr) continue;
      s += t[i] * t[j] * d(j, i);
      wt += t[i] * t[j];
    }
  *depth = s / wt;
  *intensity = gs / gw;
}

TEST(PyramidRow, ReferenceFollowsTheRule) {
  // 12 coarse pixels over 24 finer columns: a plane, a 2 m step, a slope, a hole, a lone far pixel.
  FinerRows w(24);
  for (int j = 0; j < 4; ++j)
    for (int c = 0; c < 24; ++c) {
      float d = 1.0f;                                                   // columns 0-5: a plane at 1 m
      if (c >= 6 && c < 10) d = c < 8 ? 1.0f : 3.0f;                    // a step between 7 and 8
      if (c >= 10 && c < 16) d = 1.5f + 0.01f * static_cast<float>(c);  // a slope
      if (c >= 16 && c < 20) d = (j == 1 || j == 2) ? 0.0f : 2.0f;      // the block holds no depth
      if (c >= 20) d = (j == 2 && c == 21) ? 4.0f : 2.0f;               // one far pixel in a block
      w.depth[j][c] = d;
      w.intensity[j][c] = 10.0f * static_cast<float>(j) + static_cast<float>(c);
    }
  w.depth[0][2] = 0.0f;  // a window pixel without depth: no depth, no colour
  w.intensity[0][2] = 1.0e6f;
  std::vector<float> depth(12, -1.0f), intensity(12, -1.0f);
  pyramid_row_ref(w.params(true), 1, 11, depth.data(), intensity.data());
  EXPECT_EQ(depth[0], -1.0f);  // outside [x_begin, x_end): untouched
  EXPECT_EQ(depth[11], -1.0f);
  for (int x = 1; x < 11; ++x) {
    double want_d, want_i;
    pyramid_rule(w, x, &want_d, &want_i);
    EXPECT_NEAR(depth[x], want_d, 1e-6 * std::max(1.0, want_d)) << "x " << x;
    EXPECT_NEAR(intensity[x], want_i, 1e-4 * std::max(1.0, want_i)) << "x " << x;
  }
  EXPECT_EQ(depth[1], 1.0f);  // the plane, a window pixel missing
  EXPECT_LT(intensity[1], 1000.0f) << "the pixel without depth gives no colour";
  EXPECT_EQ(depth[3], 1.0f);  // next to the step: only the near side
  EXPECT_EQ(depth[4], 3.0f);  // and only the far side
  EXPECT_EQ(depth[8], 0.0f);  // a block without depth is a hole, whatever its window holds
  EXPECT_EQ(intensity[8], 0.0f);
  EXPECT_EQ(depth[10], 2.0f);  // the block's near surface (2 m) leaves the far pixel out
  // Depth only: the same depths.
  std::vector<float> depth_only(12, -1.0f);
  pyramid_row_ref(w.params(false), 1, 11, depth_only.data(), nullptr);
  EXPECT_EQ(std::memcmp(depth_only.data(), depth.data(), sizeof(float) * 12), 0);
}

FinerRows random_rows(std::mt19937& rng, int fw) {
  FinerRows w(fw);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int j = 0; j < 4; ++j) {
    float d = 0.5f + 3.0f * u(rng);
    for (int c = 0; c < fw; ++c) {
      const float e = u(rng);
      if (e < 0.08f) d = 0.5f + 3.0f * u(rng);  // a depth step
      d += 0.03f * (u(rng) - 0.5f);            // noise of the order of the threshold
      float v = d;
      if (e > 0.85f) v = 0.0f;                                        // no depth
      if (e > 0.97f) v = -d;                                          // negative: no depth either
      if (e > 0.995f) v = std::numeric_limits<float>::quiet_NaN();    // NaN: no depth either
      w.depth[j][c] = v;
      w.intensity[j][c] = u(rng) < 0.01f ? std::numeric_limits<float>::quiet_NaN() : 255.0f * u(rng);
    }
  }
  return w;
}

TEST(PyramidRow, EveryVariantEqualsTheReferenceBitForBit) {
  const auto variants = test::runnable_variants(kPyramidRowVariants, "pyramid_row");
  for (int n = 1; n <= 40; ++n) {  // coarse pixels 1 .. n: every length of the last step's overlap
    for (int rep = 0; rep < 4; ++rep) {
      std::mt19937 rng(1000u * static_cast<unsigned>(n) + static_cast<unsigned>(rep));
      const int fw = 2 * (n + 1) + 1 + rep % 2;  // the contract's smallest finer width, and one more
      const FinerRows w = random_rows(rng, fw);
      for (bool with_intensity : {false, true}) {
        const int cw = n + 2;  // guard pixels on both sides
        std::vector<float> want_d(cw, -1.0f), want_i(cw, -1.0f);
        pyramid_row_ref(w.params(with_intensity), 1, n + 1, want_d.data(), with_intensity ? want_i.data() : nullptr);
        for (const auto* v : variants) {
          std::vector<float> got_d(cw, -1.0f), got_i(cw, -1.0f);
          v->fn(w.params(with_intensity), 1, n + 1, got_d.data(), with_intensity ? got_i.data() : nullptr);
          EXPECT_EQ(std::memcmp(got_d.data(), want_d.data(), sizeof(float) * cw), 0)
              << v->name << " n " << n << " rep " << rep << " intensity " << with_intensity;
          EXPECT_EQ(std::memcmp(got_i.data(), want_i.data(), sizeof(float) * cw), 0)
              << v->name << " n " << n << " rep " << rep << " intensity " << with_intensity;
        }
      }
    }
  }
  // The working sizes' levels: 160 and 80 coarse pixels (interior 1 .. w - 2) of 320 and 160.
  for (int cw : {160, 80, 40}) {
    std::mt19937 rng(static_cast<unsigned>(cw));
    const FinerRows w = random_rows(rng, 2 * cw);
    std::vector<float> want_d(cw, -1.0f), want_i(cw, -1.0f);
    pyramid_row_ref(w.params(true), 1, cw - 1, want_d.data(), want_i.data());
    for (const auto* v : variants) {
      std::vector<float> got_d(cw, -1.0f), got_i(cw, -1.0f);
      v->fn(w.params(true), 1, cw - 1, got_d.data(), got_i.data());
      EXPECT_EQ(std::memcmp(got_d.data(), want_d.data(), sizeof(float) * cw), 0) << v->name << " width " << cw;
      EXPECT_EQ(std::memcmp(got_i.data(), want_i.data(), sizeof(float) * cw), 0) << v->name << " width " << cw;
    }
  }
}

TEST(PyramidRow, DispatchMatchesTheReference) {
  std::mt19937 rng(7u);
  const FinerRows w = random_rows(rng, 160);
  std::vector<float> a(80), b(80), ai(80), bi(80);
  pyramid_row(w.params(true), 1, 79, a.data(), ai.data());
  pyramid_row_ref(w.params(true), 1, 79, b.data(), bi.data());
  EXPECT_EQ(std::memcmp(a.data() + 1, b.data() + 1, sizeof(float) * 78), 0);
  EXPECT_EQ(std::memcmp(ai.data() + 1, bi.data() + 1, sizeof(float) * 78), 0);
  EXPECT_NE(pyramid_row_selected(), nullptr);
}

}  // namespace
}  // namespace ef::kernels
