// bilateral_row: the reference is the filter of its contract (against a double-precision evaluation
// of the same sum; invalid neighbours add nothing; an invalid centre stays invalid), and every
// variant the CPU can run writes the same row as the reference, bit for bit (every radius, widths
// with tails of every length, invalid pixels and the sentinel border, depth steps).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "kernel_test_util.h"
#include "kernels/bilateral_row.h"
#include "kernels/bilateral_row_variants.h"

namespace ef::kernels {
namespace {

constexpr float kSentinel = 1.0e6f;  // slam/preprocess.cpp's invalid depth in the padded image

// A padded depth image of (w + 2r) x (2r + 1) rows around one output row, the raw row, the weights.
struct Window {
  int w, r;
  std::vector<std::vector<float>> padded;
  std::vector<const float*> rows;
  std::vector<float> raw, spatial;
  Window(int w_, int r_) : w(w_), r(r_), padded(2 * r_ + 1, std::vector<float>(w_ + 2 * r_, kSentinel)),
                           raw(w_, 0.0f), spatial((2 * r_ + 1) * (2 * r_ + 1)) {
    const float inv = 1.0f / (2.0f * 2.25f * 2.25f);
    for (int dy = -r; dy <= r; ++dy)
      for (int dx = -r; dx <= r; ++dx)
        spatial[(dy + r) * (2 * r + 1) + dx + r] = std::exp(-static_cast<float>(dx * dx + dy * dy) * inv);
    for (const auto& p : padded) rows.push_back(p.data());
  }
  // Image pixel (x, row k of the window) = d (0 = invalid: the sentinel); row r is the output row.
  void set(int x, int k, float d) {
    padded[k][x + r] = d > 0.0f ? d : kSentinel;
    if (k == r) raw[x] = d;
  }
  BilateralRow params() const {
    BilateralRow b;
    b.rows = rows.data();
    b.spatial = spatial.data();
    b.raw = raw.data();
    b.radius = r;
    b.k8 = 1.0f / (2.0f * 0.03f * 0.03f) / 8.0f;
    return b;
  }
};

Window random_window(std::mt19937& rng, int w, int r) {
  Window win(w, r);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int k = 0; k <= 2 * r; ++k) {
    float d = 0.8f + 2.0f * u(rng);
    for (int x = 0; x < w; ++x) {
      const float e = u(rng);
      if (e < 0.05f) d = 0.5f + 3.0f * u(rng);  // a depth step
      d += 0.01f * (u(rng) - 0.5f);            // noise
      win.set(x, k, e > 0.9f ? 0.0f : d);      // 10% invalid
    }
  }
  return win;
}

TEST(BilateralRow, ReferenceIsTheNormalisedWeightedSum) {
  std::mt19937 rng(3u);
  const Window win = random_window(rng, 40, 2);
  const BilateralRow b = win.params();
  std::vector<float> out(40, -1.0f);
  bilateral_row_ref(b, 40, out.data());
  int valid = 0;
  for (int x = 0; x < 40; ++x) {
    if (!(win.raw[x] > 0.0f)) {
      EXPECT_EQ(out[x], 0.0f) << "an invalid centre stays invalid, x " << x;
      continue;
    }
    ++valid;
    double sw = 0, swd = 0;
    const double c = win.raw[x];
    for (int dy = 0; dy <= 4; ++dy)
      for (int dx = 0; dx <= 4; ++dx) {
        const double nb = win.padded[dy][x + dx];
        if (nb >= kSentinel) continue;  // invalid neighbours and the border add nothing
        const double t = (nb - c) * (nb - c) * b.k8;
        const double wgt = win.spatial[dy * 5 + dx] * std::pow(1.0 + t, -8.0);
        sw += wgt;
        swd += wgt * nb;
      }
    EXPECT_NEAR(out[x], swd / sw, 1e-5) << "x " << x;
  }
  EXPECT_GT(valid, 30);
}

TEST(BilateralRow, EveryVariantEqualsTheReferenceBitForBit) {
  const auto variants = test::runnable_variants(kBilateralRowVariants, "bilateral_row");
  for (int r = 1; r <= 8; ++r) {
    for (int w : {1, 3, 4, 5, 8, 15, 16, 17, 33, 320}) {
      std::mt19937 rng(100u * static_cast<unsigned>(r) + static_cast<unsigned>(w));
      const Window win = random_window(rng, w, r);
      std::vector<float> want(w, -1.0f);
      bilateral_row_ref(win.params(), w, want.data());
      for (const auto* v : variants) {
        std::vector<float> got(w + 1, -1.0f);
        v->fn(win.params(), w, got.data());
        EXPECT_EQ(std::memcmp(got.data(), want.data(), w * sizeof(float)), 0) << v->name << " r " << r << " w " << w;
        EXPECT_EQ(got[w], -1.0f) << v->name << ": wrote past the row";
      }
    }
  }
}

TEST(BilateralRow, DispatchMatchesTheReference) {
  std::mt19937 rng(9u);
  const Window win = random_window(rng, 100, 2);
  std::vector<float> a(100), b(100);
  bilateral_row(win.params(), 100, a.data());
  bilateral_row_ref(win.params(), 100, b.data());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), sizeof(float) * 100), 0);
  EXPECT_NE(bilateral_row_selected(), nullptr);
}

}  // namespace
}  // namespace ef::kernels
