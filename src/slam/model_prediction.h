// Model prediction: the surfel map rendered at a camera pose, ElasticFusion-style (Whelan et al.,
// RSS 2015, sections 3.2 and 4.1). One call makes one pass over the surfel pool and produces:
//
//   (a) the IndexMap (slam/index_map.h) for fusion's data association: every surfel (stable or not)
//       whose centre lies between the clip planes is projected as a single point into a grid
//       `index_map_scale` times finer than the working image; the nearest centre (smallest camera z)
//       wins each index pixel.
//
//   (b) the predicted model maps the tracker aligns the next frame with (frame-to-model tracking),
//       at the working resolution and in the camera frame of T_world_cam, with the conventions of
//       slam/preprocess.h (vertex invalid = (0,0,0), unit normals facing the camera, intensity 0..255
//       grey, gradients Sobel / 8). Only surfels that are stable (confidence >= the tracking
//       threshold), inside the active time window and facing the camera take part. Each is drawn as
//       a disc (splat): every pixel whose ray meets the surfel's plane within `radius` of its centre
//       gets the ray-plane intersection as its vertex (more exact than the centre; a plane of
//       surfels predicts the plane itself). The nearest intersection wins, except that within a depth
//       band (splat_tie_depth_fraction) the disc centred nearest the pixel's ray wins, so that discs
//       of one surface do not compete on noise. Vertex, normal and colour are resolved once per pixel
//       afterwards from the winning surfel ("deferred shading"), so the overdraw of overlapping discs
//       costs only a depth test per covered pixel.
//
//   (c) the coarser levels, built like the current frame's (slam/preprocess.h) so that reference and
//       current pyramids are smoothed alike: depth = [1 3 3 1] binomial over the 4x4 window of the
//       finer level's predicted depths on the near surface of the central 2x2 block, vertex = that
//       depth back-projected on the coarse pixel's ray, normal = central differences of the coarse
//       vertices (none across a depth step), intensity = the same binomial over predicted pixels.
//       (Averaging the finer normals instead, as ElasticFusion does with its fused and therefore
//       smooth normals, was measured worse while the map is young: see model_prediction.cpp.)
//       Gradients on every level treat missing neighbours as equal to the centre (no edge at the
//       border of a hole), and holes then get the mean intensity of their predicted 3x3 neighbours,
//       so that the tracker's bilinear sampling next to a hole does not blend in black.
//
// Level l has exactly the size and intrinsics Intrinsics::pyramid_level(l) of the working intrinsics
// (as the Preprocessor's), so predictor.pyramid_view() can be the tracker's reference:
//   tracker.track(predictor.pyramid_view(), pyramid_view(preprocessor), guess, &result);
// The tracker's result is then T_ref_cur with ref = the camera of the pose given to predict().
//
// Cost (bench/slam_predict.cpp): the pool is read in blocks of 256 surfels; a branch-free loop
// transforms and projects a block (vectorised; surfels behind the camera or outside the clip range
// are masked, not branched on), then a scalar loop scatters the centres into the index map, another
// branch-free loop sets up the block's discs (vectorised too) and the discs of the tracking
// candidates are tested pixel by pixel by kernels/splat_disc (SIMD across the pixels of a row:
// SSE4.1 / AVX2 / NEON, bit-identical to its scalar twin); resolve() prefetches the
// next row's winners. Measured (thread CPU time, one x86-64 core of a shared machine, 320x240,
// fusion-sized radii, 300k surfels of which ~80k discs in view): 13.9 ms with scalar disc rows,
// 10.4 ms with the kernel (AVX2); the transform and index map are ~1.9 ms of that, resolve 1.3 ms,
// the pyramid 1.6 ms.
//
// Memory: create() allocates everything (at 320x240, scale 1, 3 levels: 1.8 MB of index map, 3.6 MB
// of level-0 buffers and maps, 1.0 MB for levels 1-2); predict() performs no heap allocation.
// Threads: one ModelPredictor per thread; predict() and the accessors must not run concurrently.
#pragma once

#include <climits>
#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/options.h"
#include "core/result.h"
#include "core/se3.h"
#include "slam/index_map.h"
#include "slam/surfel_pool.h"
#include "slam/tracker.h"

namespace ef::slam {

struct PredictionOptions {
  // Index map resolution: index pixels per working pixel along each axis (1..4); fusion must use the
  // same scale. ElasticFusion uses 4 at 640x480, up to 16 candidate surfels per input pixel. Default
  // 1 here: at the 320x240 working resolution a finer map buys no accuracy, only time. Measured at
  // 320x240 on one x86-64 core (bench/slam_stages, all 1000 7-Scenes frames, the pool in spatial
  // order): 4x gave fuse 11.95 + predict 10.57 ms median, ATE 2.77 cm, 467k surfels at the end, and
  // 2x 10.92 + 8.05 ms, ATE 2.74 cm, 391k surfels (one run); later, side by side with today's
  // fusion rules, 2x 11.26 + 9.65 ms, ATE 2.77 cm, 383k surfels against 1x 9.30 + 9.02 ms, ATE
  // 2.76 cm, 428k surfels. Synthetic 1000-frame loop: ATE 5.4 mm at 2x, 5.6 mm at 1x (5.3 mm at 4x
  // before); semantic Table I class average: SF +1.7 over the CNN at both 2x and 1x, SF-CRF +1.8 /
  // +1.9 (docs/results.md). `run`: mapping.index_map_scale.
  int index_map_scale = 1;
  // Surfels with confidence >= this (dimensionless accumulated weight) are stable and drawn into the
  // tracking maps (ElasticFusion: 10). predict(..., tracking_min_confidence) overrides it per call
  // (e.g. while the map is young and no surfel can have reached it yet).
  float stable_confidence = 10.0f;
  // Frames: surfels whose last_seen is more than this many frames before the predicted frame are
  // left out of the tracking maps (ElasticFusion's active / inactive time window: 200). 0 = no limit.
  // The index map always holds every surfel.
  int32_t active_window_frames = 200;
  // Cap of a disc's footprint, half-width in working pixels (> 0, at most 64). A surfel seen much
  // closer than when it was created would otherwise cover a large area per surfel; beyond the cap
  // its disc is clipped to a square of this half-width. 8 px at 320x240: a surfel created at
  // radius sqrt(2) z / f (1.4 px) stays uncapped until seen about 5.7 times closer.
  float max_splat_radius_px = 8.0f;
  // Clip planes, metres along the optical axis: surfel centres outside [near, far] are not drawn in
  // either map (0 < near < far). 0.1 m keeps the projection well-conditioned (no structured-light
  // sensor measures that close); 8 m is the preprocessing depth cut-off (SemanticFusion): the
  // current frame has no depth beyond it, so model points there would have nothing to match.
  float near_clip_m = 0.1f;
  float far_clip_m = 8.0f;
  // Visibility between overlapping discs, as a fraction of depth (dimensionless, 0..0.1). A pixel
  // is owned by the disc with the smallest z (1 + splat_tie_depth_fraction e^2 / r^2), z the depth of
  // the ray's intersection with the disc's plane, e its distance from the disc's centre and r the
  // radius: a disc nearer by more than this fraction of the depth always wins (occlusion), while
  // among discs of one surface (intersections within the band) the one centred nearest the ray wins.
  // Without the band the most forward of several noisy coplanar intersections wins, which pulls the
  // predicted surface toward the camera. Measured on the noisy synthetic office (320x240, a model
  // made from frame 10, frame 12 tracked against it; frame-to-frame tracking of the same pair:
  // 1.50 mm): band 0 -> 11.9 mm translation error, 0.005 -> 8.8 mm, 0.01 -> 4.5 mm, 0.02 -> 1.56 mm,
  // 0.05 -> 1.69 mm. 0.02 is 4 cm at 2 m for e = r, several times a Kinect's depth noise there, and
  // well below the depth gap of most occlusion edges. 0 = plain z-test.
  float splat_tie_depth_fraction = 0.02f;
  // Coarse levels: a finer depth takes part in a coarse pixel when it is within this distance
  // (metres) of the near surface of the central 2x2 block, so a coarse pixel on a step edge takes one
  // surface rather than a depth between (KinectFusion: 3 sigma_depth; preprocessing's default 0.09 m).
  float pyramid_depth_threshold_m = 0.09f;
  // Coarse-level normals: none where a neighbour's depth differs from the centre's by more than a
  // surface at this grazing angle (degrees between surface and viewing ray, 0..90 exclusive) would
  // give over one pixel, z / (f tan(angle)). 5 deg as preprocessing's normal_min_grazing_deg.
  float normal_min_grazing_deg = 5.0f;

  // The keys `run` offers (section mapping): index_map_scale.
  static const opt::Table<PredictionOptions>& table();
  // An error naming the first field out of range.
  Status validate() const;
  // One line per field with its unit, for logs.
  std::string describe() const;
};

// Totals of the last predict() call.
struct PredictionCounters {
  int64_t blocks = 0;          // blocks of the pool (SurfelPool::kBoundsBlock ids each)
  int64_t blocks_visited = 0;  // of those, blocks whose bounds may reach the view and window drawn
  int64_t index_surfels = 0;     // surfels whose centre landed in the index grid (= IndexMap::surfels_drawn)
  int64_t tracking_candidates = 0;  // stable, in-window, front-facing, within the clip range and
                                    // centred within max_splat_radius_px of the image
  int64_t splatted_surfels = 0;  // of those, surfels whose disc overlapped the image and was rasterised
  int64_t valid_pixels = 0;      // level-0 pixels with a predicted vertex
};

// Milliseconds spent by the last predict() call, per stage (steady clock).
struct PredictionTimings {
  double clear_ms = 0;    // resetting the index map and the level-0 depth / winner buffers
  double render_ms = 0;   // the pass over the pool: transform, index map scatter, disc rasterisation
  double resolve_ms = 0;  // level-0 vertex, normal, colour and intensity from the winning surfels
  double pyramid_ms = 0;  // coarser levels, gradients and hole filling of every level
  double total_ms = 0;
};

// One predicted level (conventions of slam/preprocess.h; camera frame of the predicted pose).
struct PredictedLevel {
  Intrinsics intrinsics;          // Intrinsics::pyramid_level(l) of the working intrinsics
  Image<float> depth;             // camera z of the vertex, metres; 0 = none
  Image<Eigen::Vector3f> vertex;  // metres; invalid = (0, 0, 0)
  Image<Eigen::Vector3f> normal;  // unit, toward the camera; invalid = (0, 0, 0)
  Image<float> intensity;         // grey 0..255 (0.299 R + 0.587 G + 0.114 B); holes hold their
                                  // neighbours' mean (or 0): test the vertex for validity
  Image<float> grad_x, grad_y;    // Sobel / 8, grey levels per pixel of this level; 0 in holes
};

// Whether predict() also draws the index map at the predicted pose (a pass over the surfels in
// view): kSkip when nothing reads it before the next render_index_map() (SurfelSlam: fusion renders
// its own at the tracked pose); draw_index_map_at_prediction() makes it later on demand.
enum class IndexMapDraw : uint8_t { kDraw, kSkip };

class ModelPredictor {
 public:
  // Allocates every buffer for a working image of working.width x working.height and `levels`
  // pyramid levels (1..kTrackerMaxLevels; the coarsest must be at least 8x8, as the Preprocessor's).
  // Errors (kInvalidArgument): invalid options, intrinsics or level count.
  static Result<ModelPredictor> create(const Intrinsics& working, int levels, const PredictionOptions& options = {});
  // Bytes create() allocates for a width x height working image, `levels` levels and options'
  // index_map_scale; bytes() of a created predictor.
  static std::size_t bytes_for(int width, int height, int levels, const PredictionOptions& options);
  std::size_t bytes() const;

  ModelPredictor(ModelPredictor&&) noexcept = default;
  ModelPredictor& operator=(ModelPredictor&&) noexcept = default;

  // Renders `pool` seen from T_world_cam (camera to world) for frame `frame_index` (the frame the
  // active window is measured from). The tracking maps use surfels with confidence >=
  // options().stable_confidence; the second form uses `tracking_min_confidence` instead (>= 0,
  // finite). Everything of the previous call is overwritten. Errors (kInvalidArgument): a bad
  // tracking_min_confidence. No heap allocation.
  Status predict(const SurfelPool& pool, const SE3& T_world_cam, int32_t frame_index);
  Status predict(const SurfelPool& pool, const SE3& T_world_cam, int32_t frame_index, float tracking_min_confidence,
                 IndexMapDraw index = IndexMapDraw::kDraw);
  // The inactive model (ElasticFusion's loop closure): the same maps from the surfels last seen
  // before frame `seen_before` only, whatever their age. No heap allocation.
  Status predict_inactive(const SurfelPool& pool, const SE3& T_world_cam, int32_t seen_before,
                          float tracking_min_confidence);

  // Renders only the index map, at T_world_cam (the tracking maps stay those of the last predict()):
  // fusion associates a tracked frame through the map rendered at its own pose (ElasticFusion),
  // which costs the transform and scatter of the pool instead of a whole prediction (7-Scenes at
  // 320x240, bench_slam_stages: median 1.6 ms against 6.0 ms for predict()). No heap allocation.
  // seen_since: surfels last seen before this frame are left out (ElasticFusion's fusion sees the
  // active model only); INT32_MIN = every surfel.
  void render_index_map(const SurfelPool& pool, const SE3& T_world_cam, int32_t seen_since = INT32_MIN);

  // Draws the index map at the last predict()'s pose, every surfel, as predict() with kDraw would
  // have (a no-op when it did): `pool` must be unchanged since that predict(). No heap allocation.
  void draw_index_map_at_prediction(const SurfelPool& pool);
  // Whether index_map() is the one at the last predict()'s pose.
  bool index_map_at_prediction() const { return index_at_maps_pose_; }

  // The index map of the last predict() with kDraw, draw_index_map_at_prediction() or
  // render_index_map() (its T_world_cam says which pose; ids valid until the pool next removes a
  // surfel).
  const IndexMap& index_map() const { return index_map_; }
  // The predicted maps as the tracker's reference pyramid (valid until the next predict()); every
  // level has intensity and gradient views.
  PyramidView pyramid_view() const;

  int levels() const { return levels_; }
  const PredictedLevel& level(int l) const { return level_[l]; }
  const Intrinsics& intrinsics() const { return level_[0].intrinsics; }
  // Level 0: camera z of the predicted vertex (metres, 0 = none), the winning surfel's colour
  // (black where none) and its id (-1 where none).
  ImageView<const float> depth() const { return level_[0].depth.view(); }
  ImageView<const Rgb8> color() const { return color_.view(); }
  ImageView<const int32_t> surfel_ids() const { return winner_.view(); }
  // The pose of the last predict(), the tracking maps' (camera to world); identity before the first.
  const SE3& pose() const { return maps_pose_; }

  const PredictionCounters& counters() const { return counters_; }
  const PredictionTimings& timings() const { return timings_; }
  const PredictionOptions& options() const { return options_; }

 private:
  ModelPredictor() = default;
  struct Pose;  // the float camera transform of one render (model_prediction.cpp)
  static Pose make_pose(const SE3& T_world_cam, float min_confidence, int32_t oldest_frame, int32_t seen_before);
  Status predict_seen(const SurfelPool& pool, const SE3& T_world_cam, float tracking_min_confidence, int32_t oldest,
                      int32_t seen_before, IndexMapDraw index);
  void clear_index_map();
  void clear_tracking_maps();
  // Index map, and the discs of the tracking candidates (none when pose.min_confidence is infinite).
  void render(const SurfelPool& pool, const Pose& pose, PredictionCounters& counters);
  void resolve(const SurfelPool& pool, const Pose& pose);
  void vertex_normal(int l);
  void gradients_and_holes(int l);

  PredictionOptions options_;
  int levels_ = 0;
  PredictedLevel level_[kTrackerMaxLevels];
  IndexMap index_map_;
  SE3 maps_pose_;           // the pose of the last predict()
  bool index_at_maps_pose_ = false;  // index_map_ was drawn at maps_pose_ from every surfel
  // level_[0].depth holds, while rendering, the visibility key z (1 + tie e^2 / r^2) of the disc
  // owning each pixel (+inf = none); resolve() replaces it by the depth.
  Image<int32_t> winner_;   // level 0: the surfel owning each pixel, -1 = none
  Image<Rgb8> color_;       // level 0: that surfel's colour
  Image<float> ray_x_;      // (x - cx) / fx for every level-0 column (1 row), metres per metre of z
  Image<float> ray_y_;      // (y - cy) / fy for every level-0 row (1 row)
  Image<float> row_scratch_;  // one level-0 row of fill_holes() output
  PredictionCounters counters_;
  PredictionTimings timings_;
};

}  // namespace ef::slam
