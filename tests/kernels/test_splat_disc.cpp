// splat_disc: every variant the CPU can run writes the same key and winner buffers as the scalar
// reference, bit for bit (random discs of every size and orientation, boxes touching every border,
// images as narrow as a vector, NaN normals, successive discs overdrawing each other); boxes are
// respected (nothing outside them changes); and a disc in front of a plane covers what it should.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "kernel_test_util.h"
#include "kernels/splat_disc.h"
#include "kernels/splat_disc_variants.h"

namespace ef::kernels {
namespace {

struct Canvas {
  int w, h;
  std::vector<float> ray_x, ray_y, key;
  std::vector<int32_t> winner;
  Canvas(int w_, int h_) : w(w_), h(h_), ray_x(w_), ray_y(h_), key(static_cast<std::size_t>(w_) * h_),
                           winner(static_cast<std::size_t>(w_) * h_, -1) {
    const float f = 0.9f * static_cast<float>(w_);
    for (int x = 0; x < w; ++x) ray_x[x] = (static_cast<float>(x) - 0.5f * static_cast<float>(w - 1)) / f;
    for (int y = 0; y < h; ++y) ray_y[y] = (static_cast<float>(y) - 0.5f * static_cast<float>(h - 1)) / f;
    std::fill(key.begin(), key.end(), std::numeric_limits<float>::infinity());
  }
};

// A random disc in front of the camera, roughly facing it, with a random box inside the image.
SplatDisc random_disc(std::mt19937& rng, int w, int h, int32_t id) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), z(0.3f, 6.0f), rad(0.001f, 0.2f);
  SplatDisc d;
  d.zc = z(rng);
  d.xc = u(rng) * d.zc * 0.6f;
  d.yc = u(rng) * d.zc * 0.5f;
  float nx = u(rng) * 0.8f, ny = u(rng) * 0.8f, nz = -1.0f;
  const float len = std::sqrt(nx * nx + ny * ny + nz * nz);
  d.nx = nx / len;
  d.ny = ny / len;
  d.nz = nz / len;
  if (id % 7 == 3) d.nz = -d.nz;  // some back-facing
  d.np = d.nx * d.xc + d.ny * d.yc + d.nz * d.zc;
  const float r = rad(rng);
  d.r2 = r * r;
  d.tie = (id % 5 == 0 ? 0.0f : 0.02f) / d.r2;
  d.near = 0.1f;
  d.id = id;
  std::uniform_int_distribution<int> px(0, w - 1), py(0, h - 1), ext(0, 17);
  const int cx = px(rng), cy = py(rng), ex = ext(rng), ey = ext(rng) / 2;
  d.x0 = std::max(0, cx - ex);
  d.x1 = std::min(w - 1, cx + ex + (id % 3));
  d.y0 = std::max(0, cy - ey);
  d.y1 = std::min(h - 1, cy + ey);
  if (id % 11 == 0) {  // hugging a border
    d.x1 = w - 1;
    d.x0 = std::max(0, w - 1 - ext(rng));
  }
  if (id % 13 == 0) {
    d.x0 = 0;
    d.x1 = std::min(w - 1, ext(rng));
  }
  return d;
}

TEST(SplatDisc, EveryVariantEqualsTheReferenceBitForBit) {
  const auto variants = test::runnable_variants(kSplatDiscVariants, "splat_disc");
  for (int w : {1, 3, 4, 5, 7, 8, 9, 16, 33, 320}) {
    const int h = w < 8 ? 5 : std::min(w, 60);
    std::mt19937 rng(1234u + static_cast<unsigned>(w));
    std::vector<SplatDisc> discs;
    for (int i = 0; i < 600; ++i) discs.push_back(random_disc(rng, w, h, i));
    discs[5].nx = std::numeric_limits<float>::quiet_NaN();  // a NaN normal never wins
    Canvas ref(w, h);
    for (const SplatDisc& d : discs) splat_disc_ref(d, ref.ray_x.data(), ref.ray_y.data(), ref.key.data(), ref.winner.data(), w);
    int covered = 0;
    for (int32_t id : ref.winner) covered += id >= 0;
    if (w >= 16) {
      EXPECT_GT(covered, 100) << "width " << w;  // the comparison below is not of empty buffers
    }
    for (const auto* v : variants) {
      Canvas c(w, h);
      for (const SplatDisc& d : discs) v->fn(d, c.ray_x.data(), c.ray_y.data(), c.key.data(), c.winner.data(), w);
      EXPECT_EQ(0, std::memcmp(c.key.data(), ref.key.data(), ref.key.size() * sizeof(float)))
          << v->name << " width " << w;
      EXPECT_EQ(c.winner, ref.winner) << v->name << " width " << w;
    }
  }
}

TEST(SplatDisc, WritesOnlyInsideTheBox) {
  const int w = 40, h = 20;
  for (const auto* v : test::runnable_variants(kSplatDiscVariants, "splat_disc")) {
    Canvas c(w, h);
    SplatDisc d;  // a huge fronto-parallel disc at 1 m: covers every pixel of its box
    d.nz = -1.0f;
    d.zc = 1.0f;
    d.np = -1.0f;
    d.r2 = 100.0f;
    d.near = 0.1f;
    d.id = 7;
    d.x0 = 33;
    d.x1 = 38;
    d.y0 = 4;
    d.y1 = 6;
    v->fn(d, c.ray_x.data(), c.ray_y.data(), c.key.data(), c.winner.data(), w);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const bool inside = x >= d.x0 && x <= d.x1 && y >= d.y0 && y <= d.y1;
        EXPECT_EQ(c.winner[y * w + x], inside ? 7 : -1) << v->name << " at " << x << "," << y;
        EXPECT_EQ(std::isfinite(c.key[y * w + x]), inside) << v->name << " at " << x << "," << y;
      }
  }
}

TEST(SplatDisc, NearerDiscWinsAndDispatchMatchesReference) {
  const int w = 24, h = 12;
  Canvas a(w, h), b(w, h);
  SplatDisc far_disc;
  far_disc.nz = -1.0f;
  far_disc.zc = 3.0f;
  far_disc.np = -3.0f;
  far_disc.r2 = 100.0f;
  far_disc.near = 0.1f;
  far_disc.id = 1;
  far_disc.x1 = w - 1;
  far_disc.y1 = h - 1;
  SplatDisc near_disc = far_disc;
  near_disc.zc = 2.0f;
  near_disc.np = -2.0f;
  near_disc.id = 2;
  near_disc.x0 = 5;
  near_disc.x1 = 9;
  splat_disc(far_disc, a.ray_x.data(), a.ray_y.data(), a.key.data(), a.winner.data(), w);
  splat_disc(near_disc, a.ray_x.data(), a.ray_y.data(), a.key.data(), a.winner.data(), w);
  splat_disc(far_disc, a.ray_x.data(), a.ray_y.data(), a.key.data(), a.winner.data(), w);  // loses now
  for (const SplatDisc* d : {&far_disc, &near_disc, &far_disc})
    splat_disc_ref(*d, b.ray_x.data(), b.ray_y.data(), b.key.data(), b.winner.data(), w);
  EXPECT_EQ(a.winner, b.winner);
  EXPECT_EQ(0, std::memcmp(a.key.data(), b.key.data(), a.key.size() * sizeof(float)));
  for (int x = 0; x < w; ++x) EXPECT_EQ(a.winner[3 * w + x], x >= 5 && x <= 9 ? 2 : 1) << x;
  EXPECT_NE(splat_disc_selected(), nullptr);
}

}  // namespace
}  // namespace ef::kernels
