// gradient_fill_row: the reference follows its contract (an intensity ramp's Sobel gradient, no edge
// at a hole's border, zero gradient and a filled mean where there is no prediction, 0 where no
// neighbour has one), and every variant the CPU can run writes the same three rows as the reference,
// bit for bit (row lengths with every overlap of the last step, holes, NaN), and nothing outside its
// range.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "kernel_test_util.h"
#include "kernels/gradient_fill_row.h"
#include "kernels/gradient_fill_row_variants.h"

namespace ef::kernels {
namespace {

struct ShadeRows {
  int w;
  std::vector<float> intensity[3], depth[3];
  explicit ShadeRows(int w_) : w(w_) {
    for (int k = 0; k < 3; ++k) {
      intensity[k].assign(w_, 0.0f);
      depth[k].assign(w_, 1.0f);
    }
  }
  GradientFillRow params() const {
    GradientFillRow r;
    for (int k = 0; k < 3; ++k) {
      r.intensity[k] = intensity[k].data();
      r.depth[k] = depth[k].data();
    }
    return r;
  }
};

struct Out {
  std::vector<float> gx, gy, filled;
  explicit Out(int w) : gx(w, -7.0f), gy(w, -7.0f), filled(w, -7.0f) {}
  bool operator==(const Out& o) const {
    const auto same = [](const std::vector<float>& a, const std::vector<float>& b) {
      return std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
    };
    return same(gx, o.gx) && same(gy, o.gy) && same(filled, o.filled);
  }
};

TEST(GradientFillRow, ReferenceFollowsTheRule) {
  // Intensity 10 x + 3 y: gradient (10, 3) per pixel everywhere a full 3x3 neighbourhood is predicted.
  ShadeRows rows(12);
  for (int k = 0; k < 3; ++k)
    for (int x = 0; x < 12; ++x) rows.intensity[k][x] = 10.0f * static_cast<float>(x) + 3.0f * static_cast<float>(k);
  rows.depth[1][6] = 0.0f;  // a hole at (6, y)
  rows.intensity[1][6] = 1.0e6f;
  rows.depth[0][10] = rows.depth[1][10] = rows.depth[2][10] = 0.0f;  // a hole column at 10,
  rows.depth[0][9] = rows.depth[1][9] = rows.depth[2][9] = 0.0f;     // and at 9: (10) has one neighbour column
  rows.depth[0][11] = rows.depth[2][11] = 0.0f;                       // (11, y) alone predicted to its right
  Out out(12);
  gradient_fill_row_ref(rows.params(), 1, 11, out.gx.data(), out.gy.data(), out.filled.data());
  EXPECT_EQ(out.gx[0], -7.0f);  // outside [x_begin, x_end): untouched
  EXPECT_EQ(out.filled[11], -7.0f);
  for (int x : {1, 2, 3, 4}) {
    EXPECT_EQ(out.gx[x], 10.0f) << x;
    EXPECT_EQ(out.gy[x], 3.0f) << x;
    EXPECT_EQ(out.filled[x], rows.intensity[1][x]) << "a predicted pixel keeps its intensity, x " << x;
  }
  // Next to the hole the hole's tap takes the centre's value: the gradient is not an edge.
  EXPECT_LT(out.gx[5], 10.0f);
  EXPECT_GT(out.gx[5], 0.0f);
  EXPECT_LT(out.gx[5], 1000.0f) << "the hole's own intensity must not leak in";
  // The hole: no gradient, filled with its eight predicted neighbours' mean.
  EXPECT_EQ(out.gx[6], 0.0f);
  EXPECT_EQ(out.gy[6], 0.0f);
  EXPECT_NEAR(out.filled[6], (50.0f + 60.0f + 70.0f + 53.0f + 73.0f + 56.0f + 66.0f + 76.0f) / 8.0f, 1e-4f);
  // (10, y): its only predicted neighbour is (11, y); (9, y) has those of column 8.
  EXPECT_EQ(out.filled[10], rows.intensity[1][11]);
  EXPECT_NEAR(out.filled[9], (80.0f + 83.0f + 86.0f) / 3.0f, 1e-4f);
  // No predicted neighbour at all: 0.
  ShadeRows empty(5);
  for (int k = 0; k < 3; ++k)
    for (int x = 0; x < 5; ++x) {
      empty.depth[k][x] = 0.0f;
      empty.intensity[k][x] = 42.0f;
    }
  Out e(5);
  gradient_fill_row_ref(empty.params(), 1, 4, e.gx.data(), e.gy.data(), e.filled.data());
  for (int x = 1; x < 4; ++x) EXPECT_EQ(e.filled[x], 0.0f) << x;
}

ShadeRows random_shade_rows(std::mt19937& rng, int w) {
  ShadeRows rows(w);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int k = 0; k < 3; ++k)
    for (int x = 0; x < w; ++x) {
      const float e = u(rng);
      rows.depth[k][x] = e < 0.3f ? 0.0f : 0.5f + 3.0f * u(rng);  // 30% holes
      if (e > 0.995f) rows.depth[k][x] = std::numeric_limits<float>::quiet_NaN();
      rows.intensity[k][x] = u(rng) < 0.005f ? std::numeric_limits<float>::quiet_NaN() : 255.0f * u(rng);
    }
  return rows;
}

TEST(GradientFillRow, EveryVariantEqualsTheReferenceBitForBit) {
  const auto variants = test::runnable_variants(kGradientFillRowVariants, "gradient_fill_row");
  for (int n = 1; n <= 40; ++n) {
    for (int rep = 0; rep < 4; ++rep) {
      std::mt19937 rng(300u * static_cast<unsigned>(n) + static_cast<unsigned>(rep));
      const int w = n + 2;
      const ShadeRows rows = random_shade_rows(rng, w);
      Out want(w);
      gradient_fill_row_ref(rows.params(), 1, n + 1, want.gx.data(), want.gy.data(), want.filled.data());
      for (const auto* v : variants) {
        Out got(w);
        v->fn(rows.params(), 1, n + 1, got.gx.data(), got.gy.data(), got.filled.data());
        EXPECT_TRUE(got == want) << v->name << " n " << n << " rep " << rep;
      }
    }
  }
  for (int w : {320, 160, 80}) {
    std::mt19937 rng(static_cast<unsigned>(w));
    const ShadeRows rows = random_shade_rows(rng, w);
    Out want(w);
    gradient_fill_row_ref(rows.params(), 1, w - 1, want.gx.data(), want.gy.data(), want.filled.data());
    for (const auto* v : variants) {
      Out got(w);
      v->fn(rows.params(), 1, w - 1, got.gx.data(), got.gy.data(), got.filled.data());
      EXPECT_TRUE(got == want) << v->name << " width " << w;
    }
  }
}

TEST(GradientFillRow, DispatchMatchesTheReference) {
  std::mt19937 rng(13u);
  const ShadeRows rows = random_shade_rows(rng, 100);
  Out a(100), b(100);
  gradient_fill_row(rows.params(), 1, 99, a.gx.data(), a.gy.data(), a.filled.data());
  gradient_fill_row_ref(rows.params(), 1, 99, b.gx.data(), b.gy.data(), b.filled.data());
  EXPECT_TRUE(a == b);
  EXPECT_NE(gradient_fill_row_selected(), nullptr);
}

}  // namespace
}  // namespace ef::kernels
