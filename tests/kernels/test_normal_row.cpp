// normal_row: the reference follows its contract (a tilted plane's normal against the plane's own,
// facing the camera; no normal at a depth step, next to a pixel without depth or at a grazing
// angle), and every variant the CPU can run writes the same row as the reference, bit for bit (row
// lengths with every overlap of the last step, missing depth, steps, NaN), and nothing outside its
// range.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "kernel_test_util.h"
#include "kernels/normal_row.h"
#include "kernels/normal_row_variants.h"

namespace ef::kernels {
namespace {

constexpr float kFocal = 290.0f, kCentre = 20.0f;  // focal length and principal point, pixels

// Three vertex rows of `w` pixels (x, y, z each), from a depth per pixel as the vertex map holds it.
struct VertexRows {
  int w;
  std::vector<float> v[3];
  explicit VertexRows(int w_) : w(w_) {
    for (auto& r : v) r.assign(3 * w_, 0.0f);
  }
  void set(int k, int x, float d) {  // row k (0: y - 1), pixel x: depth d (<= 0 or NaN: none)
    const float u = static_cast<float>(x), vv = static_cast<float>(k - 1);
    const bool ok = d > 0.0f;
    v[k][3 * x] = ok ? ((u - kCentre) * d) / kFocal : 0.0f;
    v[k][3 * x + 1] = ok ? ((vv - kCentre) * d) / kFocal : 0.0f;
    v[k][3 * x + 2] = ok ? d : 0.0f;
  }
  NormalRow params(bool divide = false) const {
    NormalRow r;
    r.divide = divide;
    for (int k = 0; k < 3; ++k) r.vertex[k] = v[k].data();
    const float inv_tan = 1.0f / std::tan(5.0f * 3.14159265f / 180.0f);  // 5 degrees from grazing
    r.step_x = inv_tan / kFocal;
    r.step_y = inv_tan / kFocal;
    return r;
  }
};

TEST(NormalRow, ReferenceGivesThePlanesNormalFacingTheCamera) {
  // The plane n . X = 2 with n = (0.3, -0.2, -1) normalised: depth at pixel (u, v) is 2 / (n . ray).
  const float n[3] = {0.3f, -0.2f, -1.0f};
  const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  const int w = 24;
  VertexRows rows(w);
  for (int k = 0; k < 3; ++k)
    for (int x = 0; x < w; ++x) {
      const float rx = (static_cast<float>(x) - kCentre) / kFocal, ry = (static_cast<float>(k - 1) - kCentre) / kFocal;
      rows.set(k, x, -2.0f * len / (n[0] * rx + n[1] * ry + n[2]));
    }
  rows.set(1, 10, 0.0f);         // no depth: no normal there, nor next to it
  rows.set(1, 16, 4.0f);         // a depth step
  std::vector<float> out(3 * w, -7.0f);
  normal_row_ref(rows.params(), 1, w - 1, out.data());
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(out[k], -7.0f);  // outside [x_begin, x_end): untouched
    EXPECT_EQ(out[3 * (w - 1) + k], -7.0f);
  }
  for (int x = 1; x < w - 1; ++x) {
    const float* o = &out[3 * x];
    if (x >= 9 && x <= 11) {
      EXPECT_TRUE(o[0] == 0.0f && o[1] == 0.0f && o[2] == 0.0f) << "no depth at or next to x " << x;
      continue;
    }
    if (x >= 15 && x <= 17) {
      EXPECT_TRUE(o[0] == 0.0f && o[1] == 0.0f && o[2] == 0.0f) << "a depth step at or next to x " << x;
      continue;
    }
    EXPECT_NEAR(o[0], n[0] / len, 2e-3) << x;  // the plane's normal, pointing toward the camera (z < 0)
    EXPECT_NEAR(o[1], n[1] / len, 2e-3) << x;
    EXPECT_NEAR(o[2], n[2] / len, 2e-3) << x;
    EXPECT_NEAR(o[0] * o[0] + o[1] * o[1] + o[2] * o[2], 1.0f, 1e-5f) << x;
  }
  // Dividing by the length instead of multiplying by its reciprocal: the same normals within rounding.
  std::vector<float> divided(3 * w, -7.0f);
  normal_row_ref(rows.params(true), 1, w - 1, divided.data());
  for (int i = 3; i < 3 * (w - 1); ++i) EXPECT_NEAR(divided[i], out[i], 1e-6f) << i;
  // A plane seen at a grazing angle (the depth step between neighbours beyond 5 degrees): no normal.
  VertexRows steep(8);
  for (int k = 0; k < 3; ++k)
    for (int x = 0; x < 8; ++x) steep.set(k, x, 1.0f + 0.2f * static_cast<float>(x));
  std::vector<float> s(24, -7.0f);
  normal_row_ref(steep.params(), 1, 7, s.data());
  for (int i = 3; i < 21; ++i) EXPECT_EQ(s[i], 0.0f) << i;
}

VertexRows random_vertex_rows(std::mt19937& rng, int w) {
  VertexRows rows(w);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> base(w);  // a surface across the rows, with steps
  float d = 0.5f + 3.0f * u(rng);
  for (int x = 0; x < w; ++x) {
    if (u(rng) < 0.05f) d = 0.5f + 3.0f * u(rng);
    d += 0.01f * (u(rng) - 0.5f);
    base[x] = d;
  }
  for (int k = 0; k < 3; ++k)
    for (int x = 0; x < w; ++x) {
      const float e = u(rng);
      rows.set(k, x, e > 0.93f ? 0.0f : base[x] + 0.004f * (u(rng) - 0.5f));
      if (e > 0.995f) rows.v[k][3 * x + 2] = std::numeric_limits<float>::quiet_NaN();
    }
  return rows;
}

TEST(NormalRow, EveryVariantEqualsTheReferenceBitForBit) {
  const auto variants = test::runnable_variants(kNormalRowVariants, "normal_row");
  int with_normal = 0;
  for (int n = 1; n <= 40; ++n) {  // pixels 1 .. n: every length of the last step's overlap
    for (int rep = 0; rep < 4; ++rep) {
      std::mt19937 rng(500u * static_cast<unsigned>(n) + static_cast<unsigned>(rep));
      const int w = n + 2;
      const VertexRows rows = random_vertex_rows(rng, w);
      for (bool divide : {false, true}) {
        std::vector<float> want(3 * w, -7.0f);
        normal_row_ref(rows.params(divide), 1, n + 1, want.data());
        for (int x = 1; x <= n; ++x) with_normal += want[3 * x + 2] != 0.0f;
        for (const auto* v : variants) {
          std::vector<float> got(3 * w, -7.0f);
          v->fn(rows.params(divide), 1, n + 1, got.data());
          EXPECT_EQ(std::memcmp(got.data(), want.data(), sizeof(float) * 3 * w), 0)
              << v->name << " n " << n << " rep " << rep << " divide " << divide;
        }
      }
    }
  }
  EXPECT_GT(with_normal, 500) << "the comparison must include pixels that have a normal";
  for (int w : {320, 160, 80}) {
    std::mt19937 rng(static_cast<unsigned>(w));
    const VertexRows rows = random_vertex_rows(rng, w);
    std::vector<float> want(3 * w, -7.0f);
    normal_row_ref(rows.params(), 1, w - 1, want.data());
    for (const auto* v : variants) {
      std::vector<float> got(3 * w, -7.0f);
      v->fn(rows.params(), 1, w - 1, got.data());
      EXPECT_EQ(std::memcmp(got.data(), want.data(), sizeof(float) * 3 * w), 0) << v->name << " width " << w;
    }
  }
}

TEST(NormalRow, DispatchMatchesTheReference) {
  std::mt19937 rng(11u);
  const VertexRows rows = random_vertex_rows(rng, 100);
  std::vector<float> a(300, -7.0f), b(300, -7.0f);
  normal_row(rows.params(), 1, 99, a.data());
  normal_row_ref(rows.params(), 1, 99, b.data());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), sizeof(float) * 300), 0);
  EXPECT_NE(normal_row_selected(), nullptr);
}

}  // namespace
}  // namespace ef::kernels
