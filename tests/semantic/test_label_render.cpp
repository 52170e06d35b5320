// render_labels: a fronto-parallel wall of surfels, one per working pixel, seen by a small camera.
// Each pixel shows its surfel's most likely class; the nearer of two surfels in a pixel wins; pixels
// without a surfel, or whose surfel was never observed (uniform store), take the fallback.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/se3.h"
#include "semantic/label_render.h"
#include "semantic/label_store.h"
#include "slam/model_prediction.h"
#include "slam/surfel_pool.h"

namespace ef::semantic {
namespace {

constexpr int kW = 40, kH = 30;
const Intrinsics kCamera{40, 40, 19.5, 14.5, kW, kH};

// Costs with class `c` most likely (cost 0) and every other class at cost 40 (e^-2.5 of it).
void set_class(slam::SurfelPool& pool, int64_t id, int c) {
  uint8_t* s = pool.labels() + id * 16;
  for (int k = 0; k < kLabelClasses; ++k) s[k] = k == c ? 0 : 40;
}

// A surfel facing the camera (identity pose) on the ray through pixel (u + 0.125, v + 0.125) at depth
// z, with a disc of `radius_px` pixels (0.6: it covers only its own pixel's centre).
int64_t add_at_pixel(slam::SurfelPool& pool, int u, int v, float z, float radius_px = 0.6f) {
  const float x = (float(u) + 0.125f - float(kCamera.cx)) / float(kCamera.fx) * z;
  const float y = (float(v) + 0.125f - float(kCamera.cy)) / float(kCamera.fy) * z;
  return pool.append(x, y, z, 0, 0, -1, radius_px * z / float(kCamera.fx), 20.0f, slam::pack_rgb(90, 90, 90), 0);
}

TEST(LabelRender, MapClassNearestSurfelAndFallback) {
  slam::SurfelPoolOptions po;
  po.capacity = 4 * kW * kH;
  auto pool = slam::SurfelPool::create(po);
  ASSERT_TRUE(pool.ok());
  // Columns 0..29 hold a plane at 2 m: class 5 (floor) left of column 15, class 12 (wall) from 15 on;
  // columns 30..39 hold nothing. Row 5 of the plane was never observed (uniform).
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < 30; ++u) {
      const int64_t id = add_at_pixel(*pool, u, v, 2.0f);
      if (v != 5) set_class(*pool, id, u < 15 ? 5 : 12);
    }
  // Pixel (3, 20) also shows a surfel 0.5 m in front, labelled chair (4): it must win there.
  set_class(*pool, add_at_pixel(*pool, 3, 20, 1.5f), 4);
  // A surfel behind the wall at (20, 20), labelled tv (11): hidden.
  set_class(*pool, add_at_pixel(*pool, 20, 20, 3.0f), 11);
  // In the empty columns, a window (13) surfel at (35, 25) whose disc (1.5 px) covers its neighbours:
  // they have no centre in their cells and take it from the disc (rule 2).
  set_class(*pool, add_at_pixel(*pool, 35, 25, 2.0f, 1.5f), 13);
  const auto in_window_disc = [](int u, int v) {
    const double du = u - 35.125, dv = v - 25.125;
    return du * du + dv * dv < 1.5 * 1.5;
  };

  slam::PredictionOptions popt;
  popt.splat_tie_depth_fraction = 0.0f;
  auto predictor = slam::ModelPredictor::create(kCamera, 1, popt);
  ASSERT_TRUE(predictor.ok());
  ASSERT_TRUE(predictor->predict(*pool, SE3(), 0).ok());

  Image<uint8_t> fallback(kW, kH), out(kW, kH);
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) fallback(u, v) = 10;  // table
  auto counts = render_labels(*predictor, *pool, fallback.view(), out.view());
  ASSERT_TRUE(counts.ok()) << to_string(counts.error());

  int64_t map_pixels = 0, fallback_pixels = 0, disc_pixels = 0;
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) {
      int want;
      if (in_window_disc(u, v)) {
        want = 13;
        if (u != 35 || v != 25) ++disc_pixels;
      } else if (u >= 30 || v == 5) want = 10;
      else if (u == 3 && v == 20) want = 4;
      else want = u < 15 ? 5 : 12;
      ASSERT_EQ(out(u, v), want) << u << "," << v;
      ++(want == 10 ? fallback_pixels : map_pixels);
    }
  EXPECT_EQ(disc_pixels, 7);  // centres within 1.5 px of (35.125, 25.125), its own pixel aside
  EXPECT_EQ(counts->from_index_map, map_pixels - disc_pixels);  // every plane pixel has a centre in its cells
  EXPECT_EQ(counts->from_splat, disc_pixels);
  EXPECT_EQ(counts->from_fallback, fallback_pixels);

  // No fallback image: those pixels are unknown (0).
  ASSERT_TRUE(render_labels(*predictor, *pool, {}, out.view()).ok());
  EXPECT_EQ(out(35, 10), 0);
  EXPECT_EQ(out(10, 5), 0);
  EXPECT_EQ(out(10, 10), 5);
}

TEST(LabelRender, RejectsWrongSizes) {
  slam::SurfelPoolOptions po;
  po.capacity = 16;
  auto pool = slam::SurfelPool::create(po);
  ASSERT_TRUE(pool.ok());
  auto predictor = slam::ModelPredictor::create(kCamera, 1);
  ASSERT_TRUE(predictor.ok());
  ASSERT_TRUE(predictor->predict(*pool, SE3(), 0).ok());
  Image<uint8_t> small(kW - 1, kH), right(kW, kH);
  auto r = render_labels(*predictor, *pool, {}, small.view());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(to_string(r.error()).find("39x30"), std::string::npos) << to_string(r.error());
  EXPECT_FALSE(render_labels(*predictor, *pool, small.view(), right.view()).ok());
  // An empty pool: everything falls back.
  Image<uint8_t> fb(kW, kH);
  fb(7, 7) = 3;
  auto ok = render_labels(*predictor, *pool, fb.view(), right.view());
  ASSERT_TRUE(ok.ok());
  EXPECT_EQ(ok->from_fallback, int64_t(kW) * kH);
  EXPECT_EQ(right(7, 7), 3);
}

}  // namespace
}  // namespace ef::semantic
