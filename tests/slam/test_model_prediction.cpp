// ModelPredictor: analytic planes of surfels (index map ids and depths, ray-plane vertices, normals),
// the depth test in both maps, which surfels the tracking maps admit (stable, active window, facing),
// clipping, pyramid sizes and contents, gradients of a colour ramp, a round trip through a synthetic
// frame (frame -> surfels -> prediction ~ frame), and the tracker aligning a frame with a prediction.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "io/frame_source.h"
#include "slam/model_prediction.h"
#include "slam/preprocess.h"
#include "slam/preprocess_test_util.h"
#include "slam/tracker.h"
#include "synth/synthetic_source.h"
#include "synth/test_synth_support.h"

namespace ef::slam {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

SurfelPool make_prediction_pool(int64_t capacity = 200'000) {
  SurfelPoolOptions o;
  o.capacity = capacity;
  auto p = SurfelPool::create(o);
  EXPECT_TRUE(p.ok());
  return std::move(p).value();
}

// The index-map tests below place surfels on the cells of a 4x index map (ElasticFusion's scale;
// the default is 2): they use these options unless they pass their own.
PredictionOptions scale4_options() {
  PredictionOptions o;
  o.index_map_scale = 4;
  return o;
}

ModelPredictor make_predictor(const Intrinsics& K, int levels = 3, const PredictionOptions& o = scale4_options()) {
  auto p = ModelPredictor::create(K, levels, o);
  EXPECT_TRUE(p.ok()) << to_string(p.error());
  return std::move(p).value();
}

// Appends a surfel given in the camera frame of T_wc (position and normal), stored in world.
int64_t add_cam(SurfelPool& pool, const SE3& T_wc, const Eigen::Vector3d& p_c, const Eigen::Vector3d& n_c,
                double radius, float confidence, uint32_t color = pack_rgb(100, 150, 200), int32_t frame = 0) {
  const Eigen::Vector3d p = T_wc * p_c;
  const Eigen::Vector3d n = T_wc.rotation() * n_c;
  return pool.append(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()),
                     static_cast<float>(n.x()), static_cast<float>(n.y()), static_cast<float>(n.z()),
                     static_cast<float>(radius), confidence, color, frame);
}

// A camera pose away from the identity, so that every test also checks the world-to-camera transform.
SE3 some_pose() {
  Vector6d xi;
  xi << 0.3, -0.2, 1.1, 0.2, -0.35, 0.1;
  return SE3::exp(xi);
}

// A plane in the camera frame: {X : n . X = d}, n unit toward the camera (n . X < 0 on the plane).
struct Plane {
  Eigen::Vector3d n;
  double d;
  // Camera z of the plane point on the ray through working pixel (u, v).
  double depth(const Intrinsics& K, double u, double v) const {
    const Eigen::Vector3d ray((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
    return d / n.dot(ray);
  }
};

Plane tilted_plane(double z0) {
  const Eigen::Vector3d n = Eigen::Vector3d(0.25, -0.15, -1.0).normalized();
  return Plane{n, n.z() * z0};  // through (0, 0, z0)
}

// One surfel per working pixel of the plane, each centred on the ray through (u + o, v + o) with
// o = 0.125: at index scale 4 that is the centre of index pixel (4u + 2, 4v + 2), far from any
// rounding boundary. Radius sqrt(2) z / fx / |cos(incidence)| (fusion's rule): the discs overlap.
// Returns the surfel id of each working pixel (row-major).
std::vector<int64_t> fill_plane(SurfelPool& pool, const Intrinsics& K, const SE3& T_wc, const Plane& plane,
                                float confidence, uint32_t color = pack_rgb(100, 150, 200)) {
  std::vector<int64_t> ids;
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const double uo = u + 0.125, vo = v + 0.125;
      const double z = plane.depth(K, uo, vo);
      const Eigen::Vector3d p((uo - K.cx) / K.fx * z, (vo - K.cy) / K.fy * z, z);
      const double cos_inc = std::fabs(plane.n.dot(p.normalized()));
      ids.push_back(add_cam(pool, T_wc, p, plane.n, std::sqrt(2.0) * z / K.fx / cos_inc, confidence, color));
    }
  return ids;
}

Intrinsics small_camera() { return Intrinsics{120, 120, 39.5, 29.5, 80, 60}; }

TEST(ModelPredict, OptionsValidateAndDescribe) {
  EXPECT_TRUE(PredictionOptions{}.validate().ok());
  const auto expect_bad = [](PredictionOptions o, const char* field) {
    const Status s = o.validate();
    ASSERT_FALSE(s.ok()) << field;
    EXPECT_NE(s.error().message.find(field), std::string::npos) << s.error().message;
    auto created = ModelPredictor::create(small_camera(), 3, o);
    EXPECT_FALSE(created.ok()) << field;
  };
  PredictionOptions o;
  o.index_map_scale = 0;
  expect_bad(o, "index_map_scale");
  o = {};
  o.index_map_scale = 5;
  expect_bad(o, "index_map_scale");
  o = {};
  o.stable_confidence = -1;
  expect_bad(o, "stable_confidence");
  o = {};
  o.stable_confidence = NAN;
  expect_bad(o, "stable_confidence");
  o = {};
  o.active_window_frames = -1;
  expect_bad(o, "active_window_frames");
  o = {};
  o.max_splat_radius_px = 0;
  expect_bad(o, "max_splat_radius_px");
  o = {};
  o.max_splat_radius_px = 100;
  expect_bad(o, "max_splat_radius_px");
  o = {};
  o.near_clip_m = 0;
  expect_bad(o, "near_clip_m");
  o = {};
  o.far_clip_m = 0.05f;
  expect_bad(o, "far_clip_m");
  o = {};
  o.far_clip_m = INFINITY;
  expect_bad(o, "far_clip_m");
  o = {};
  o.pyramid_depth_threshold_m = 0;
  expect_bad(o, "pyramid_depth_threshold_m");
  o = {};
  o.normal_min_grazing_deg = 90;
  expect_bad(o, "normal_min_grazing_deg");
  o = {};
  o.splat_tie_depth_fraction = -0.01f;
  expect_bad(o, "splat_tie_depth_fraction");

  const std::string d = PredictionOptions{}.describe();
  for (const char* f : {"index_map_scale", "stable_confidence", "active_window_frames", "max_splat_radius_px",
                        "near_clip_m", "far_clip_m", "splat_tie_depth_fraction", "pyramid_depth_threshold_m",
                        "normal_min_grazing_deg"})
    EXPECT_NE(d.find(f), std::string::npos) << f;
}

TEST(ModelPredict, CreateRejectsBadSizesAndLevels) {
  EXPECT_FALSE(ModelPredictor::create(Intrinsics{}, 3, {}).ok());
  EXPECT_FALSE(ModelPredictor::create(small_camera(), 0, {}).ok());
  EXPECT_FALSE(ModelPredictor::create(small_camera(), kTrackerMaxLevels + 1, {}).ok());
  EXPECT_FALSE(ModelPredictor::create(small_camera(), 4, {}).ok());  // 80x60 -> level 3 is 10x7
  EXPECT_TRUE(ModelPredictor::create(small_camera(), 3, {}).ok());
  auto p = make_predictor(small_camera());
  SurfelPool pool = make_prediction_pool(10);
  EXPECT_FALSE(p.predict(pool, SE3(), 0, -1.0f).ok());
  EXPECT_FALSE(p.predict(pool, SE3(), 0, NAN).ok());
}

// bytes() (and the memory plan's bytes_for()) is what create() allocated: every level's maps, the
// index map (ids, depths, surfaces), the winner and colour images, plus the three rows of rays and scratch (private).
TEST(ModelPredict, BytesAreWhatCreateAllocated) {
  for (int scale : {1, 2, 4}) {
    PredictionOptions o;
    o.index_map_scale = scale;
    const ModelPredictor p = make_predictor(small_camera(), 3, o);
    const auto b = [](const auto& view) { return static_cast<std::size_t>(view.width) * view.height * sizeof(*view.data); };
    std::size_t sum = 0;
    for (int l = 0; l < p.levels(); ++l) {
      const PredictedLevel& lv = p.level(l);
      sum += b(lv.depth.view()) + b(lv.vertex.view()) + b(lv.normal.view()) + b(lv.intensity.view()) +
             b(lv.grad_x.view()) + b(lv.grad_y.view());
    }
    sum += b(p.index_map().id.view()) + b(p.index_map().depth.view()) + b(p.index_map().surface.view()) +
           b(p.surfel_ids()) + b(p.color());
    sum += (2 * static_cast<std::size_t>(small_camera().width) + small_camera().height) * sizeof(float);
    EXPECT_EQ(p.bytes(), sum) << "scale " << scale;
    EXPECT_EQ(ModelPredictor::bytes_for(small_camera().width, small_camera().height, 3, o), sum) << "scale " << scale;
  }
}

// Fusion gates on the index map's copy of each surfel's normal and confidence (slam/index_map.h):
// with several surfels competing for most index pixels (random depths, normals and confidences),
// every occupied pixel holds exactly what the pool has for the surfel whose id it holds, the same as
// copy_surfaces_from_pool gives, at each scale.
TEST(ModelPredict, IndexMapSurfacesAreThoseOfItsSurfels) {
  const Intrinsics K = small_camera();
  const SE3 T_wc = some_pose();
  SurfelPool pool = make_prediction_pool();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int i = 0; i < 20000; ++i) {
    const double z = 0.5 + 3.0 * unit(rng);
    const Eigen::Vector3d p_c(((K.width - 1) * unit(rng) - K.cx) / K.fx * z, ((K.height - 1) * unit(rng) - K.cy) / K.fy * z, z);
    const Eigen::Vector3d n_c = Eigen::Vector3d(unit(rng) - 0.5, unit(rng) - 0.5, -1.0).normalized();
    const int64_t id = add_cam(pool, T_wc, p_c, n_c, 0.005, static_cast<float>(30.0 * unit(rng)));
    ASSERT_GE(id, 0);
  }
  for (int scale : {1, 2, 4}) {
    PredictionOptions o;
    o.index_map_scale = scale;
    auto p = make_predictor(K, 3, o);
    ASSERT_TRUE(p.predict(pool, T_wc, 0).ok());
    const IndexMap& im = p.index_map();
    IndexMap copy;
    copy.id.allocate(im.id.width(), im.id.height());
    copy.id.copy_from(im.id.view());
    copy_surfaces_from_pool(pool, copy);
    int64_t occupied = 0;
    for (int y = 0; y < im.id.height(); ++y)
      for (int x = 0; x < im.id.width(); ++x) {
        const int32_t id = im.id(x, y);
        if (id < 0) continue;
        ++occupied;
        const IndexSurface& s = im.surface(x, y);
        ASSERT_EQ(s.nx, pool.nx()[id]) << x << "," << y << " scale " << scale;
        ASSERT_EQ(s.ny, pool.ny()[id]);
        ASSERT_EQ(s.nz, pool.nz()[id]);
        ASSERT_EQ(s.confidence, pool.confidence()[id]);
        ASSERT_EQ(std::memcmp(&s, &copy.surface(x, y), sizeof(IndexSurface)), 0);
      }
    // Most pixels were contested: far fewer occupied pixels than surfels at scale 1.
    if (scale == 1) {
      EXPECT_LT(occupied, pool.size() / 2);
    }
    EXPECT_GT(occupied, 1000);
  }
}

TEST(ModelPredict, EmptyPoolGivesEmptyMaps) {
  auto p = make_predictor(small_camera());
  // Before any predict() the maps are empty too (the index map says -1, not surfel 0).
  EXPECT_EQ(p.index_map().id(5, 5), -1);
  SurfelPool pool = make_prediction_pool(10);
  ASSERT_TRUE(p.predict(pool, some_pose(), 0).ok());
  EXPECT_EQ(p.counters().valid_pixels, 0);
  EXPECT_EQ(p.index_map().surfels_drawn, 0);
  for (int y = 0; y < p.index_map().id.height(); ++y)
    for (int x = 0; x < p.index_map().id.width(); ++x) ASSERT_EQ(p.index_map().id(x, y), -1);
}

// A tilted plane of surfels seen from a general pose: every index pixel that a centre projects to holds
// that surfel's id and depth, every other is empty; every level-0 pixel holds the exact ray-plane
// intersection and the plane's normal in the camera frame.
TEST(ModelPredict, PlaneGivesAnalyticMapsAndIds) {
  const Intrinsics K = small_camera();
  const SE3 T_wc = some_pose();
  const Plane plane = tilted_plane(2.0);
  SurfelPool pool = make_prediction_pool();
  const std::vector<int64_t> ids = fill_plane(pool, K, T_wc, plane, 20.0f);
  auto p = make_predictor(K);
  ASSERT_TRUE(p.predict(pool, T_wc, 0).ok());

  const IndexMap& im = p.index_map();
  ASSERT_EQ(im.scale, 4);
  ASSERT_EQ(im.id.width(), 4 * K.width);
  ASSERT_EQ(im.id.height(), 4 * K.height);
  EXPECT_EQ(im.surfels_drawn, pool.size());
  EXPECT_EQ(p.counters().index_surfels, pool.size());
  int64_t occupied = 0;
  for (int y = 0; y < im.id.height(); ++y)
    for (int x = 0; x < im.id.width(); ++x) {
      const bool centre = x % 4 == 2 && y % 4 == 2;
      if (!centre) {
        ASSERT_EQ(im.id(x, y), -1) << x << "," << y;
        ASSERT_EQ(im.depth(x, y), 0.0f);
        continue;
      }
      const int u = x / 4, v = y / 4;
      ASSERT_EQ(im.id(x, y), ids[static_cast<std::size_t>(v) * K.width + u]) << u << "," << v;
      ASSERT_NEAR(im.depth(x, y), plane.depth(K, u + 0.125, v + 0.125), 2e-5);
      ++occupied;
    }
  EXPECT_EQ(occupied, pool.size());

  EXPECT_EQ(p.counters().tracking_candidates, pool.size());
  EXPECT_EQ(p.counters().valid_pixels, K.width * K.height);
  const PredictedLevel& l0 = p.level(0);
  double max_err = 0, max_nerr = 0;
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const double z = plane.depth(K, u, v);
      const Eigen::Vector3d expected((u - K.cx) / K.fx * z, (v - K.cy) / K.fy * z, z);
      max_err = std::max(max_err, (l0.vertex(u, v).cast<double>() - expected).norm());
      max_nerr = std::max(max_nerr, (l0.normal(u, v).cast<double>() - plane.n).norm());
      ASSERT_FLOAT_EQ(p.depth()(u, v), l0.vertex(u, v).z());
      ASSERT_EQ(p.color()(u, v), (Rgb8{100, 150, 200}));
      ASSERT_NEAR(l0.intensity(u, v), 0.299 * 100 + 0.587 * 150 + 0.114 * 200, 1e-3);
      ASSERT_GE(p.surfel_ids()(u, v), 0);
    }
  std::printf("[ predict ] plane: max vertex error %.3g m, max normal error %.3g\n", max_err, max_nerr);
  EXPECT_LT(max_err, 5e-5);  // float round-off at 2 m
  EXPECT_LT(max_nerr, 1e-5);
  // A uniform colour has no gradient.
  for (int l = 0; l < p.levels(); ++l)
    for (int v = 0; v < p.level(l).intrinsics.height; ++v)
      for (int u = 0; u < p.level(l).intrinsics.width; ++u) {
        ASSERT_NEAR(p.level(l).grad_x(u, v), 0.0f, 1e-3);
        ASSERT_NEAR(p.level(l).grad_y(u, v), 0.0f, 1e-3);
      }
}

// The index map of other scales uses the half-pixel-centre grid of Intrinsics::scaled_to.
TEST(ModelPredict, IndexMapScalesOneAndTwo) {
  const Intrinsics K = small_camera();
  for (int s : {1, 2}) {
    PredictionOptions o;
    o.index_map_scale = s;
    auto p = make_predictor(K, 3, o);
    SurfelPool pool = make_prediction_pool(10);
    // A surfel on the ray through working pixel (30.3, 20.4): index coordinate (u + 0.5) s - 0.5.
    const double u = 30.3, v = 20.4, z = 1.5;
    const int64_t id = add_cam(pool, SE3(), Eigen::Vector3d((u - K.cx) / K.fx * z, (v - K.cy) / K.fy * z, z),
                               Eigen::Vector3d(0, 0, -1), 0.01, 20);
    ASSERT_TRUE(p.predict(pool, SE3(), 0).ok());
    const int iu = static_cast<int>(std::floor((u + 0.5) * s - 0.5 + 0.5));
    const int iv = static_cast<int>(std::floor((v + 0.5) * s - 0.5 + 0.5));
    EXPECT_EQ(p.index_map().id.width(), K.width * s);
    EXPECT_EQ(p.index_map().id(iu, iv), id) << "scale " << s;
    EXPECT_NEAR(p.index_map().depth(iu, iv), z, 1e-6);
  }
}

// Two surfels on one ray: the nearer wins in both maps, whichever comes first in the pool.
TEST(ModelPredict, NearerSurfelWinsInBothMaps) {
  const Intrinsics K = small_camera();
  const SE3 T_wc = some_pose();
  const double u = 40.125, v = 25.125;  // index pixel (162, 102)
  const Eigen::Vector3d ray((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
  for (bool near_first : {true, false}) {
    SurfelPool pool = make_prediction_pool(10);
    int64_t near_id = -1, far_id = -1;
    const Eigen::Vector3d n(0, 0, -1);
    // Radii: near 0.01 m at 1 m = 1.2 px, far 0.08 m at 2 m = 4.8 px (fx = 120).
    if (near_first) near_id = add_cam(pool, T_wc, ray * 1.0, n, 0.01, 20, pack_rgb(255, 0, 0));
    far_id = add_cam(pool, T_wc, ray * 2.0, n, 0.08, 20, pack_rgb(0, 0, 255));
    if (!near_first) near_id = add_cam(pool, T_wc, ray * 1.0, n, 0.01, 20, pack_rgb(255, 0, 0));
    auto p = make_predictor(K);
    ASSERT_TRUE(p.predict(pool, T_wc, 0).ok());
    EXPECT_EQ(p.index_map().id(162, 102), near_id);
    EXPECT_NEAR(p.index_map().depth(162, 102), 1.0, 1e-5);
    EXPECT_EQ(p.counters().index_surfels, 2);
    // Pixel (40, 25): both discs cover it; the vertex lies on the near disc's plane z = 1.
    EXPECT_NEAR(p.level(0).vertex(40, 25).z(), 1.0, 1e-5);
    EXPECT_EQ(p.surfel_ids()(40, 25), near_id);
    EXPECT_EQ(p.color()(40, 25), (Rgb8{255, 0, 0}));
    // Two pixels to the right only the far disc covers the ray.
    EXPECT_EQ(p.surfel_ids()(42, 25), far_id);
    EXPECT_NEAR(p.level(0).vertex(42, 25).z(), 2.0, 1e-5);
  }
}

TEST(ModelPredict, UnstableSurfelsOnlyInIndexMap) {
  const Intrinsics K = small_camera();
  const SE3 T_wc = some_pose();
  SurfelPool pool = make_prediction_pool();
  fill_plane(pool, K, T_wc, tilted_plane(1.5), 5.0f);  // below the default threshold of 10
  auto p = make_predictor(K);
  ASSERT_TRUE(p.predict(pool, T_wc, 0).ok());
  EXPECT_EQ(p.index_map().surfels_drawn, pool.size());
  EXPECT_EQ(p.index_map().id(2, 2), 0);
  EXPECT_EQ(p.counters().tracking_candidates, 0);
  EXPECT_EQ(p.counters().valid_pixels, 0);
  EXPECT_FALSE(valid_vertex(p.level(0).vertex(40, 30)));
  EXPECT_FALSE(valid_vertex(p.level(2).vertex(10, 7)));
  // The per-call threshold admits them (the bootstrap of a young map).
  ASSERT_TRUE(p.predict(pool, T_wc, 0, 5.0f).ok());
  EXPECT_EQ(p.counters().valid_pixels, K.width * K.height);
  ASSERT_TRUE(p.predict(pool, T_wc, 0, 5.5f).ok());
  EXPECT_EQ(p.counters().valid_pixels, 0);
}

TEST(ModelPredict, ActiveWindowLimitsTrackingOnly) {
  const Intrinsics K = small_camera();
  const SE3 T_wc = some_pose();
  SurfelPool pool = make_prediction_pool();
  fill_plane(pool, K, T_wc, tilted_plane(1.5), 20.0f);
  for (int64_t i = 0; i < pool.size(); ++i) pool.last_seen()[i] = 10;
  auto p = make_predictor(K);  // window 200
  ASSERT_TRUE(p.predict(pool, T_wc, 210).ok());  // 200 frames old: still inside
  EXPECT_EQ(p.counters().valid_pixels, K.width * K.height);
  ASSERT_TRUE(p.predict(pool, T_wc, 211).ok());  // 201 frames old: outside
  EXPECT_EQ(p.counters().valid_pixels, 0);
  EXPECT_EQ(p.counters().tracking_candidates, 0);
  EXPECT_EQ(p.index_map().surfels_drawn, pool.size());
  // Half the surfels recent again: only those are drawn.
  for (int64_t i = 0; i < pool.size(); i += 2) pool.last_seen()[i] = 200;
  ASSERT_TRUE(p.predict(pool, T_wc, 211).ok());
  EXPECT_EQ(p.counters().tracking_candidates, (pool.size() + 1) / 2);
  // Window 0 = no limit.
  PredictionOptions o;
  o.active_window_frames = 0;
  auto q = make_predictor(K, 3, o);
  ASSERT_TRUE(q.predict(pool, T_wc, 2'000'000'000).ok());
  EXPECT_EQ(q.counters().tracking_candidates, pool.size());
  // Frame indices near the int32 limits do not wrap: at frame INT32_MIN + 5 every surfel was seen
  // "later" (last_seen 10 or 200), which is not older than the window, so all are candidates.
  ASSERT_TRUE(p.predict(pool, T_wc, INT32_MIN + 5).ok());
  EXPECT_EQ(p.counters().tracking_candidates, pool.size());
  ASSERT_TRUE(p.predict(pool, T_wc, INT32_MAX).ok());
  EXPECT_EQ(p.counters().tracking_candidates, 0);
}

TEST(ModelPredict, BackFacingSurfelsSkipped) {
  const Intrinsics K = small_camera();
  const SE3 T_wc = some_pose();
  Plane away = tilted_plane(1.5);
  away.n = -away.n;
  away.d = -away.d;  // the same plane, normal pointing away from the camera
  SurfelPool pool = make_prediction_pool();
  fill_plane(pool, K, T_wc, away, 20.0f);
  auto p = make_predictor(K);
  ASSERT_TRUE(p.predict(pool, T_wc, 0).ok());
  EXPECT_EQ(p.index_map().surfels_drawn, pool.size());  // fusion still sees them
  EXPECT_EQ(p.counters().tracking_candidates, 0);
  EXPECT_EQ(p.counters().valid_pixels, 0);
  // Seen from behind the plane (camera moved through it), they face the camera and are drawn.
  // 3 m forward (the plane is at 1.5 m on the optical axis), turned around about y.
  const SE3 behind = T_wc * SE3(Eigen::Matrix3d(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY())),
                                Eigen::Vector3d(0, 0, 3.0));
  ASSERT_TRUE(p.predict(pool, behind, 0).ok());
  EXPECT_GT(p.counters().tracking_candidates, 0);
  EXPECT_GT(p.counters().valid_pixels, 0);
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const Eigen::Vector3f& x = p.level(0).vertex(u, v);
      if (valid_vertex(x)) {
        ASSERT_LT(p.level(0).normal(u, v).dot(x), 0.0f);  // normals face the camera
      }
    }
}

TEST(ModelPredict, ClipPlanesAndSurfelsBehindCamera) {
  const Intrinsics K = small_camera();
  SurfelPool pool = make_prediction_pool(10);
  const Eigen::Vector3d n(0, 0, -1);
  add_cam(pool, SE3(), Eigen::Vector3d(0, 0, 9.0), n, 0.1, 20);     // beyond far (8 m)
  add_cam(pool, SE3(), Eigen::Vector3d(0, 0, 0.05), n, 0.001, 20);  // nearer than near (0.1 m)
  add_cam(pool, SE3(), Eigen::Vector3d(0, 0, -2.0), n, 0.1, 20);    // behind the camera
  add_cam(pool, SE3(), Eigen::Vector3d(0, 0, 0), n, 0.1, 20);       // at the camera centre
  add_cam(pool, SE3(), Eigen::Vector3d(50, 0, 1), n, 0.1, 20);      // far outside the image
  add_cam(pool, SE3(), Eigen::Vector3d(1e30, -1e30, 1), n, 0.1, 20);  // absurd, must not break anything
  auto p = make_predictor(K);
  ASSERT_TRUE(p.predict(pool, SE3(), 0).ok());
  EXPECT_EQ(p.index_map().surfels_drawn, 0);
  EXPECT_EQ(p.counters().splatted_surfels, 0);
  EXPECT_EQ(p.counters().valid_pixels, 0);
  add_cam(pool, SE3(), Eigen::Vector3d(0, 0, 7.9), n, 0.1, 20);
  ASSERT_TRUE(p.predict(pool, SE3(), 0).ok());
  EXPECT_EQ(p.index_map().surfels_drawn, 1);
  EXPECT_GT(p.counters().valid_pixels, 0);
}

// A disc seen from very close is clipped to the footprint cap instead of covering the image.
TEST(ModelPredict, SplatFootprintIsCapped) {
  const Intrinsics K = small_camera();
  SurfelPool pool = make_prediction_pool(10);
  add_cam(pool, SE3(), Eigen::Vector3d(0, 0, 1.0), Eigen::Vector3d(0, 0, -1), 0.5, 20);  // 60 px radius
  PredictionOptions o;
  o.max_splat_radius_px = 3;
  auto p = make_predictor(K, 3, o);
  ASSERT_TRUE(p.predict(pool, SE3(), 0).ok());
  // Centre at the principal point (39.5, 29.5); +-3 px covers columns 37..42 and rows 27..32.
  EXPECT_EQ(p.counters().valid_pixels, 6 * 6);
  EXPECT_TRUE(valid_vertex(p.level(0).vertex(37, 27)));
  EXPECT_TRUE(valid_vertex(p.level(0).vertex(42, 32)));
  EXPECT_FALSE(valid_vertex(p.level(0).vertex(36, 29)));
  EXPECT_FALSE(valid_vertex(p.level(0).vertex(43, 29)));
}

// Each disc alone, random position, orientation (grazing included) and size: the pixels it covers are
// exactly those whose ray meets it within its radius (brute force in double over the whole image),
// so the screen bounding box never clips a disc. Pixels within 0.1% of the rim are not judged.
TEST(ModelPredict, SplatCoversExactlyThePixelsWhoseRayHitsTheDisc) {
  const Intrinsics K = small_camera();
  PredictionOptions o;
  o.max_splat_radius_px = 64;  // no cap: the bound itself is under test
  auto p = make_predictor(K, 3, o);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  int64_t judged = 0, covered = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const double z = 0.4 + 2.0 * (uni(rng) + 1.0);
    const Eigen::Vector3d c(uni(rng) * 0.5 * z, uni(rng) * 0.4 * z, z);
    Eigen::Vector3d n(uni(rng), uni(rng), uni(rng));
    n.normalize();
    if (n.dot(c) > 0) n = -n;                                            // facing the camera
    const double radius = (0.01 + 0.1 * (uni(rng) + 1.0)) * z / 2.0;   // 0.5 to 10.5 cm at 1 m
    SurfelPool pool = make_prediction_pool(4);
    add_cam(pool, SE3(), c, n, radius, 20);
    ASSERT_TRUE(p.predict(pool, SE3(), 0).ok());
    // The surfel as stored (float), so that the reference sees the same disc.
    const Eigen::Vector3d cf(pool.x()[0], pool.y()[0], pool.z()[0]);
    const Eigen::Vector3d nf(pool.nx()[0], pool.ny()[0], pool.nz()[0]);
    const double rf = pool.radius()[0];
    for (int v = 0; v < K.height; ++v)
      for (int u = 0; u < K.width; ++u) {
        const Eigen::Vector3d ray((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
        const double denom = nf.dot(ray);
        if (!(denom < 0)) continue;
        const double t = nf.dot(cf) / denom;
        const double e = (t * ray - cf).norm();
        if (std::fabs(e - rf) < 1e-3 * rf || t < 0.1) continue;
        const bool inside = e < rf;
        ++judged;
        covered += inside;
        ASSERT_EQ(valid_vertex(p.level(0).vertex(u, v)), inside)
            << "trial " << trial << " pixel " << u << "," << v << " e/r " << e / rf;
        if (inside) {
          ASSERT_NEAR(p.level(0).vertex(u, v).z(), t, 1e-4 * t);
        }
      }
  }
  std::printf("[ predict ] discs: %lld pixels judged, %lld covered\n", static_cast<long long>(judged),
              static_cast<long long>(covered));
  EXPECT_GT(covered, 10'000);
}

TEST(ModelPredict, PyramidMatchesPreprocessorSizes) {
  for (const Intrinsics& K : {test::kinect_320x240(), Intrinsics{525, 525, 319.5, 239.5, 640, 480},
                              Intrinsics{300, 300, 160, 119, 321, 239}, small_camera()}) {
    for (int levels : {1, 2, 3}) {
      PreprocessOptions po;
      po.levels = levels;
      auto pre = Preprocessor::create(K, po);
      ASSERT_TRUE(pre.ok());
      auto p = make_predictor(K, levels);
      const PyramidView view = p.pyramid_view();
      ASSERT_EQ(view.levels, levels);
      for (int l = 0; l < levels; ++l) {
        const Intrinsics& a = pre->level(l).intrinsics;
        const Intrinsics& b = p.level(l).intrinsics;
        EXPECT_EQ(a.width, b.width);
        EXPECT_EQ(a.height, b.height);
        EXPECT_EQ(a.fx, b.fx);
        EXPECT_EQ(a.fy, b.fy);
        EXPECT_EQ(a.cx, b.cx);
        EXPECT_EQ(a.cy, b.cy);
        for (auto size : {std::pair{view.level[l].vertex.width, view.level[l].vertex.height},
                          std::pair{view.level[l].normal.width, view.level[l].normal.height},
                          std::pair{view.level[l].intensity.width, view.level[l].intensity.height},
                          std::pair{view.level[l].grad_x.width, view.level[l].grad_x.height},
                          std::pair{view.level[l].grad_y.width, view.level[l].grad_y.height}}) {
          EXPECT_EQ(size.first, a.width);
          EXPECT_EQ(size.second, a.height);
        }
      }
    }
  }
}

// Coarse levels of a plane lie on the plane with its normal; a grey ramp along x gives grad_x = the
// slope (Sobel / 8 is exact on a ramp) and grad_y = 0 on every level, also next to a hole.
TEST(ModelPredict, CoarseLevelsAndGradientsOfARamp) {
  const Intrinsics K = small_camera();
  const SE3 T_wc = some_pose();
  const Plane plane = tilted_plane(1.8);
  SurfelPool pool = make_prediction_pool();
  // Grey = 2 * u (u the working column), so 2 grey levels per level-0 pixel.
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      if (u >= 50 && u < 58 && v >= 20 && v < 28) continue;  // an 8x8 hole: no surfel there
      const double uo = u + 0.125, vo = v + 0.125;
      const double z = plane.depth(K, uo, vo);
      const Eigen::Vector3d p((uo - K.cx) / K.fx * z, (vo - K.cy) / K.fy * z, z);
      const auto g = static_cast<uint8_t>(2 * u);
      add_cam(pool, T_wc, p, plane.n, 1.2 * z / K.fx, 20, pack_rgb(g, g, g));  // smaller discs keep the hole open
    }
  auto p = make_predictor(K);
  ASSERT_TRUE(p.predict(pool, T_wc, 0).ok());
  EXPECT_FALSE(valid_vertex(p.level(0).vertex(54, 24)));
  EXPECT_FALSE(valid_vertex(p.level(1).vertex(27, 12)));
  for (int l = 0; l < p.levels(); ++l) {
    const PredictedLevel& lv = p.level(l);
    const Intrinsics& k = lv.intrinsics;
    const float slope = 2.0f * static_cast<float>(1 << l);  // grey levels per pixel of level l
    int checked = 0;
    double max_off_plane = 0, max_normal_err = 0;
    for (int v = 1; v < k.height - 1; ++v)
      for (int u = 1; u < k.width - 1; ++u) {
        const Eigen::Vector3f& x = lv.vertex(u, v);
        if (!valid_vertex(x)) continue;
        // Everywhere: on the plane within 5 mm x 2^l, normal within 6 degrees. On a hole's or the
        // image's border the window is one-sided, which moves the depth by up to about one finer
        // pixel (2^(l-1) level-0 pixels) of the plane's slope (about 4 mm per level-0 pixel here), as
        // in the Preprocessor.
        const double off_plane = std::fabs(plane.n.dot(x.cast<double>()) - plane.d);
        const double normal_err = (lv.normal(u, v).cast<double>() - plane.n).norm();
        ASSERT_LT(off_plane, 5e-3 * (1 << l)) << "level " << l << " " << u << "," << v;
        if (valid_normal(lv.normal(u, v))) {
          ASSERT_LT(normal_err, 0.1) << "level " << l << " " << u << "," << v;
        }
        // The coarse vertex lies on its pixel's ray.
        const Eigen::Vector2f px = k.project(x);
        ASSERT_NEAR(px.x(), u, 1e-3f);
        ASSERT_NEAR(px.y(), v, 1e-3f);
        // Away from the image border and from the hole (whose border pixels are covered by whichever
        // neighbouring disc reaches them; the support of a level-l pixel grows by about 1.5 pixels of
        // each finer level, so the level-0 footprint of its 3x3 window is checked with a margin):
        // exact plane, normal and gradients.
        const int s = 1 << l, fx0 = (u - 2) * s - 2, fx1 = (u + 3) * s + 2, fy0 = (v - 2) * s - 2, fy1 = (v + 3) * s + 2;
        if (fx0 < 2 || fx1 >= K.width || fy0 < 0 || fy1 >= K.height || (fx1 > 50 && fx0 < 58 && fy1 > 20 && fy0 < 28))
          continue;
        max_off_plane = std::max(max_off_plane, off_plane);
        max_normal_err = std::max(max_normal_err, normal_err);
        ASSERT_NEAR(lv.grad_x(u, v), slope, 0.01f * slope) << "level " << l << " " << u << "," << v;
        ASSERT_NEAR(lv.grad_y(u, v), 0.0f, 0.01f) << "level " << l << " " << u << "," << v;
        ++checked;
      }
    std::printf("[ predict ] ramp level %d: %d interior pixels, max off-plane %.3g m, max normal error %.3g\n", l,
                checked, max_off_plane, max_normal_err);
    EXPECT_GT(checked, k.width * k.height / 5) << "level " << l;
    EXPECT_LT(max_off_plane, 2e-4) << "level " << l;
    EXPECT_LT(max_normal_err, 2e-3) << "level " << l;
  }
  // Column 50 of the hole is covered by the discs of column 49 (centre 0.875 px away, radius 1.2 px);
  // column 51 is not: it is a hole pixel next to a prediction and takes its neighbours' grey (98 or
  // 100), so bilinear sampling next to the hole does not blend in black. Deeper in, grey stays 0.
  ASSERT_TRUE(valid_vertex(p.level(0).vertex(50, 24)));
  ASSERT_FALSE(valid_vertex(p.level(0).vertex(51, 24)));
  EXPECT_NEAR(p.level(0).intensity(51, 24), 98.0f, 0.5f);
  EXPECT_EQ(p.level(0).intensity(54, 24), 0.0f);
  // Gradients are 0 in the hole and finite (no edge toward the hole) on its border.
  EXPECT_EQ(p.level(0).grad_x(51, 24), 0.0f);
  // Pixel (50, 24): its 3x3 window holds grey 98 (column 49 and the pixels its discs cover) and hole
  // pixels, which count as the centre's 98: no gradient, where a black hole would give -(98 * 4) / 8.
  EXPECT_NEAR(p.level(0).grad_x(50, 24), 0.0f, 1e-4f);
}

// A synthetic room frame turned into surfels (one per pixel with a vertex and a normal, world frame,
// radius sqrt(2) z / fx) and predicted at the same pose reproduces the preprocessed maps.
struct SynthFrames {
  std::unique_ptr<synth::SyntheticSource> src;
  Intrinsics K;
};

SynthFrames open_synth(const std::string& uri) {
  SynthFrames s{test::open_synth(uri), {}};
  if (s.src) s.K = s.src->info().intrinsics;
  return s;
}

int64_t surfels_from_frame(SurfelPool& pool, const Preprocessor& pre, const Frame& f, const SE3& T_wc,
                           float confidence) {
  const PyramidLevel& l0 = pre.level(0);
  const Intrinsics& K = l0.intrinsics;
  int64_t n = 0;
  for (int y = 0; y < K.height; ++y)
    for (int x = 0; x < K.width; ++x) {
      const Eigen::Vector3f& v = l0.vertex(x, y);
      const Eigen::Vector3f& nc = l0.normal(x, y);
      if (!valid_vertex(v) || !valid_normal(nc)) continue;
      const Rgb8 c = f.color(x, y);
      if (add_cam(pool, T_wc, v.cast<double>(), nc.cast<double>(), std::sqrt(2.0) * v.z() / K.fx, confidence,
                  pack_rgb(c.r, c.g, c.b)) >= 0)
        ++n;
    }
  return n;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

// Noise-free and noisy: with noise, neighbouring discs are not coplanar, and the visibility band
// (splat_tie_depth_fraction) is what keeps each pixel's own surfel in front of its neighbours' discs.
// Coarse levels are built differently from the Preprocessor's (vertex means instead of a filtered
// depth back-projected on the pixel ray), so there the point-to-plane distance (what ICP measures)
// is compared as well as the full vertex difference.
TEST(ModelPredict, RoundTripThroughSyntheticFrame) {
  for (const char* uri : {"synthetic:office?noise=0&frames=30&size=320x240",
                          "synthetic:office?noise=1&frames=30&size=320x240"}) {
    SynthFrames s = open_synth(uri);
    Frame f;
    f.allocate(s.K.width, s.K.height, true);
    ASSERT_TRUE(s.src->render(4, f).ok());
    const SE3 T_wc = s.src->poses()[4];
    auto pre = Preprocessor::create(s.K);
    ASSERT_TRUE(pre.ok());
    ASSERT_TRUE(pre->process(f).ok());
    SurfelPool pool = make_prediction_pool();
    const int64_t n = surfels_from_frame(pool, *pre, f, T_wc, 10.0f);
    ASSERT_GT(n, s.K.width * s.K.height / 2);
    auto p = make_predictor(s.K);
    ASSERT_TRUE(p.predict(pool, T_wc, 0).ok());
    EXPECT_EQ(p.index_map().surfels_drawn, n);

    for (int l = 0; l < 3; ++l) {
      const PyramidLevel& a = pre->level(l);
      const PredictedLevel& b = p.level(l);
      std::vector<double> err, plane_err, nerr, ierr;
      int64_t pre_valid = 0, both = 0;
      for (int y = 0; y < a.intrinsics.height; ++y)
        for (int x = 0; x < a.intrinsics.width; ++x) {
          if (!valid_vertex(a.vertex(x, y)) || !valid_normal(a.normal(x, y))) continue;
          ++pre_valid;
          if (!valid_vertex(b.vertex(x, y))) continue;
          ++both;
          err.push_back((a.vertex(x, y) - b.vertex(x, y)).norm());
          plane_err.push_back(std::fabs(a.normal(x, y).dot(b.vertex(x, y) - a.vertex(x, y))));
          if (valid_normal(b.normal(x, y)))
            nerr.push_back(std::acos(std::clamp(static_cast<double>(a.normal(x, y).dot(b.normal(x, y))), -1.0, 1.0)) *
                           kRadToDeg);
          ierr.push_back(std::fabs(a.intensity(x, y) - b.intensity(x, y)));
        }
      const auto fraction_below = [](const std::vector<double>& v, double t) {
        return static_cast<double>(std::count_if(v.begin(), v.end(), [t](double e) { return e < t; })) /
               static_cast<double>(v.size());
      };
      const double coverage = static_cast<double>(both) / static_cast<double>(pre_valid);
      std::printf("[ predict ] round trip %s level %d: coverage %.4f, vertex error median %.2f mm p95 %.2f mm, "
                  "<1 mm %.4f, <5 mm %.4f; point-to-plane p95 %.2f mm; normal median %.2f deg p95 %.2f deg; "
                  "grey median %.2f p95 %.2f\n",
                  uri + 10, l, coverage, percentile(err, 0.5) * 1e3, percentile(err, 0.95) * 1e3,
                  fraction_below(err, 0.001), fraction_below(err, 0.005), percentile(plane_err, 0.95) * 1e3,
                  percentile(nerr, 0.5), percentile(nerr, 0.95), percentile(ierr, 0.5), percentile(ierr, 0.95));
      EXPECT_GT(coverage, 0.99) << uri << " level " << l;
      if (l == 0) {
        // Each pixel is predicted from its own surfel: the frame's maps come back.
        EXPECT_GT(fraction_below(err, 0.001), 0.98) << uri;
        EXPECT_LT(percentile(nerr, 0.95), 1.0) << uri;
        EXPECT_LT(percentile(ierr, 0.95), 1.0) << uri;
      } else {
        // Built by the Preprocessor's kind of filter from the same level-0 depths, except where a
        // level-0 pixel had no normal and so gave no surfel (many more with noise). Mean normals of
        // the finer level instead of central differences fail the normal median (11 deg measured).
        const bool noisy = std::string(uri).find("noise=1") != std::string::npos;
        EXPECT_LT(percentile(err, 0.5), 0.001) << uri << " level " << l;
        EXPECT_GT(fraction_below(plane_err, 0.005), noisy ? 0.9 : 0.98) << uri << " level " << l;
        EXPECT_LT(percentile(nerr, 0.5), noisy ? 2.0 : 0.1) << uri << " level " << l;
        EXPECT_LT(percentile(ierr, 0.5), 1.0) << uri << " level " << l;
      }
    }
  }
}

// Frame-to-model tracking: the model made from frame i and predicted at its pose is the reference;
// frame j is tracked against it and the relative pose must be the true one.
TEST(ModelPredict, TrackerAlignsFrameWithPrediction) {
  for (const char* uri : {"synthetic:office?noise=0&frames=30&size=320x240",
                          "synthetic:office?noise=1&frames=30&size=320x240"}) {
    SynthFrames s = open_synth(uri);
    Frame a, b;
    a.allocate(s.K.width, s.K.height, true);
    b.allocate(s.K.width, s.K.height, true);
    const int i = 10, j = 12;
    ASSERT_TRUE(s.src->render(i, a).ok());
    ASSERT_TRUE(s.src->render(j, b).ok());
    auto pre_a = Preprocessor::create(s.K);
    auto pre_b = Preprocessor::create(s.K);
    ASSERT_TRUE(pre_a.ok() && pre_b.ok());
    ASSERT_TRUE(pre_a->process(a).ok());
    ASSERT_TRUE(pre_b->process(b).ok());
    SurfelPool pool = make_prediction_pool();
    const SE3 T_w_a = s.src->poses()[i], T_w_b = s.src->poses()[j];
    surfels_from_frame(pool, *pre_a, a, T_w_a, 10.0f);
    auto p = make_predictor(s.K);
    ASSERT_TRUE(p.predict(pool, T_w_a, 0).ok());
    auto tracker = Tracker::create(s.K, 3);
    ASSERT_TRUE(tracker.ok());
    TrackResult r;
    ASSERT_TRUE(tracker->track(p.pyramid_view(), pyramid_view(*pre_b), SE3(), &r).ok());
    const SE3 truth = T_w_a.inverse() * T_w_b;
    const SE3 d = r.T_ref_cur.inverse() * truth;
    std::printf("[ predict ] track %s: motion %.1f mm %.2f deg -> error %.3f mm %.4f deg, inliers %lld (%.2f), "
                "rgb %lld, icp rms %.2f mm%s\n",
                uri, truth.translation().norm() * 1e3, truth.angle() * kRadToDeg, d.translation().norm() * 1e3,
                d.angle() * kRadToDeg, static_cast<long long>(r.icp_inliers), r.inlier_fraction,
                static_cast<long long>(r.rgb_inliers), r.icp_rms_m * 1e3, r.lost ? " LOST" : "");
    EXPECT_FALSE(r.lost) << uri << ": " << track_lost_reason_name(r.reason);
    EXPECT_LT(d.translation().norm(), 0.005) << uri;
    EXPECT_LT(d.angle() * kRadToDeg, 0.3) << uri;
  }
}

// Predicting twice, and predicting after the pool changed, leaves no trace of the earlier call.
// render_index_map() makes the index map that predict() makes at the same pose, bit for bit, and
// leaves the tracking maps, their counters and pose() as the last predict() left them.
TEST(ModelPredict, IndexMapAloneEqualsPredictAndKeepsTrackingMaps) {
  const Intrinsics K = small_camera();
  const SE3 T_a = some_pose();
  Vector6d xi;
  xi << 0.04, -0.02, 0.03, 0.05, -0.03, 0.02;  // 5 cm, about 3.5 degrees away
  const SE3 T_b = T_a * SE3::exp(xi);
  SurfelPool pool = make_prediction_pool();
  fill_plane(pool, K, T_a, tilted_plane(1.5), 20.0f);
  fill_plane(pool, K, T_a, tilted_plane(2.5), 3.0f);  // unstable, behind: index map only, and contested
  auto at_b = make_predictor(K);
  ASSERT_TRUE(at_b.predict(pool, T_b, 0).ok());
  auto p = make_predictor(K);
  ASSERT_TRUE(p.predict(pool, T_a, 0).ok());
  const PredictionCounters counters = p.counters();
  std::vector<std::vector<float>> depth_before;
  std::vector<std::vector<Eigen::Vector3f>> vertex_before;
  for (int l = 0; l < p.levels(); ++l) {
    const PredictedLevel& lv = p.level(l);
    depth_before.emplace_back(lv.depth.data(), lv.depth.data() + lv.depth.size());
    vertex_before.emplace_back(lv.vertex.data(), lv.vertex.data() + lv.vertex.size());
  }
  const auto winners = [&p] {
    std::vector<int32_t> w;
    const ImageView<const int32_t> ids = p.surfel_ids();
    for (int y = 0; y < ids.height; ++y) w.insert(w.end(), ids.row(y), ids.row(y) + ids.width);
    return w;
  };
  const std::vector<int32_t> winners_before = winners();

  p.render_index_map(pool, T_b);
  const IndexMap& got = p.index_map();
  const IndexMap& want = at_b.index_map();
  EXPECT_EQ(got.T_world_cam.matrix(), T_b.matrix());
  EXPECT_EQ(got.surfels_drawn, want.surfels_drawn);
  ASSERT_EQ(got.id.size(), want.id.size());
  int64_t occupied = 0, moved = 0;
  for (std::size_t k = 0; k < got.id.size(); ++k) {
    ASSERT_EQ(got.id.data()[k], want.id.data()[k]) << "index pixel " << k;
    ASSERT_EQ(got.depth.data()[k], want.depth.data()[k]) << "index pixel " << k;
    if (got.id.data()[k] < 0) continue;
    ++occupied;
    ASSERT_EQ(std::memcmp(&got.surface.data()[k], &want.surface.data()[k], sizeof(IndexSurface)), 0);
  }
  EXPECT_GT(occupied, 1000);
  // The tracking maps are still those at T_a (which differ from T_b's).
  EXPECT_EQ(p.pose().matrix(), T_a.matrix());
  EXPECT_EQ(p.counters().valid_pixels, counters.valid_pixels);
  EXPECT_EQ(p.counters().splatted_surfels, counters.splatted_surfels);
  for (int l = 0; l < p.levels(); ++l) {
    const PredictedLevel& lv = p.level(l);
    EXPECT_TRUE(std::equal(depth_before[l].begin(), depth_before[l].end(), lv.depth.data())) << "level " << l;
    EXPECT_TRUE(std::equal(vertex_before[l].begin(), vertex_before[l].end(), lv.vertex.data())) << "level " << l;
    moved += std::equal(depth_before[l].begin(), depth_before[l].end(), at_b.level(l).depth.data()) ? 0 : 1;
  }
  EXPECT_EQ(moved, p.levels());  // the poses are far enough apart for every level to differ
  EXPECT_EQ(winners(), winners_before);
}

TEST(ModelPredict, EachCallStartsFromScratch) {
  const Intrinsics K = small_camera();
  const SE3 T_wc = some_pose();
  SurfelPool pool = make_prediction_pool();
  fill_plane(pool, K, T_wc, tilted_plane(1.5), 20.0f);
  auto p = make_predictor(K);
  ASSERT_TRUE(p.predict(pool, T_wc, 0).ok());
  const Eigen::Vector3f before = p.level(1).vertex(20, 15);
  ASSERT_TRUE(p.predict(pool, T_wc, 0).ok());
  EXPECT_EQ(p.level(1).vertex(20, 15), before);
  pool.clear();
  ASSERT_TRUE(p.predict(pool, T_wc, 0).ok());
  EXPECT_EQ(p.counters().valid_pixels, 0);
  EXPECT_EQ(p.index_map().id(2, 2), -1);
  for (int l = 0; l < p.levels(); ++l) EXPECT_FALSE(valid_vertex(p.level(l).vertex(5, 5)));
  EXPECT_EQ(p.color()(40, 30), (Rgb8{0, 0, 0}));
  EXPECT_EQ(p.depth()(40, 30), 0.0f);
}

// The renders skip pool blocks by their bounds (slam/surfel_pool.h); what they draw must be exactly
// what a pass over every block draws. Compared with the same pool whose bounds are stale (a mutable
// column taken), which the renders then do not use: at poses that see all, part and none of a map
// with surfaces behind the camera, off to the side and outside the active window.
TEST(ModelPredict, BlockCullingDrawsExactlyWhatAFullPassDraws) {
  const Intrinsics K = small_camera();
  const SE3 T_a = some_pose();
  Vector6d turn;
  turn << 0, 0, 0, 0, M_PI, 0;  // half a turn: the view behind T_a
  Vector6d side;
  side << 0.2, 0, 0, 0, 0.6, 0;  // part of T_a's view
  SurfelPool pool = make_prediction_pool();
  fill_plane(pool, K, T_a, tilted_plane(1.5), 20.0f);
  fill_plane(pool, K, T_a * SE3::exp(turn), tilted_plane(2.0), 20.0f);
  const std::vector<int64_t> old = fill_plane(pool, K, T_a, tilted_plane(2.5), 20.0f);
  for (int64_t id : old) pool.set_last_seen(id, -1000);  // outside the window at frame 0
  ASSERT_TRUE(pool.bounds_current());
  const auto state = [](const ModelPredictor& p) {
    std::vector<float> v;
    const IndexMap& m = p.index_map();
    for (std::size_t k = 0; k < m.id.size(); ++k) v.push_back(static_cast<float>(m.id.data()[k])), v.push_back(m.depth.data()[k]);
    const ImageView<const int32_t> w = p.surfel_ids();
    for (int y = 0; y < w.height; ++y)
      for (int x = 0; x < w.width; ++x) v.push_back(static_cast<float>(w(x, y)));
    for (int l = 0; l < p.levels(); ++l) {
      const PredictedLevel& lv = p.level(l);
      for (std::size_t k = 0; k < lv.depth.size(); ++k)
        v.insert(v.end(), {lv.depth.data()[k], lv.vertex.data()[k].x(), lv.normal.data()[k].z(), lv.intensity.data()[k],
                           lv.grad_x.data()[k]});
    }
    return v;
  };
  const SE3 poses[] = {T_a, T_a * SE3::exp(side), T_a * SE3::exp(turn), SE3::exp(Vector6d::Constant(5.0))};
  int64_t skipped = 0;
  for (const SE3& T : poses) {
    auto culled = make_predictor(K);
    ASSERT_TRUE(culled.predict(pool, T, 0).ok());
    EXPECT_EQ(culled.counters().blocks, pool.blocks());
    skipped += culled.counters().blocks - culled.counters().blocks_visited;
    auto skipless = make_predictor(K);
    (void)pool.x();  // stale: the renders visit every block
    ASSERT_TRUE(skipless.predict(pool, T, 0).ok());
    EXPECT_EQ(skipless.counters().blocks_visited, pool.blocks());
    EXPECT_EQ(state(culled), state(skipless));
    EXPECT_EQ(culled.counters().valid_pixels, skipless.counters().valid_pixels);
    EXPECT_EQ(culled.counters().index_surfels, skipless.counters().index_surfels);
    pool.refresh_bounds();
    // The index map alone, and the prediction without it drawn later on demand.
    culled.render_index_map(pool, T);
    (void)pool.x();
    skipless.render_index_map(pool, T);
    pool.refresh_bounds();
    EXPECT_EQ(state(culled), state(skipless));
    auto lazy = make_predictor(K);
    ASSERT_TRUE(lazy.predict(pool, T, 0, 10.0f, IndexMapDraw::kSkip).ok());
    EXPECT_FALSE(lazy.index_map_at_prediction());
    EXPECT_EQ(lazy.index_map().surfels_drawn, 0);
    lazy.draw_index_map_at_prediction(pool);
    EXPECT_TRUE(lazy.index_map_at_prediction());
    auto eager = make_predictor(K);
    ASSERT_TRUE(eager.predict(pool, T, 0, 10.0f).ok());
    EXPECT_TRUE(eager.index_map_at_prediction());
    EXPECT_EQ(state(lazy), state(eager));
    EXPECT_EQ(lazy.index_map().surfels_drawn, eager.index_map().surfels_drawn);
  }
  // The view behind, the far pose and the out-of-window plane leave blocks out.
  EXPECT_GT(skipped, 2 * pool.blocks());
}

}  // namespace
}  // namespace ef::slam
