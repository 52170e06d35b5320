// Surfel fusion: integrates one tracked RGB-D frame into the surfel pool, point-based fusion as in
// ElasticFusion (Whelan et al., RSS 2015, section 3) after Keller et al. (3DV 2013, "Real-time 3D
// reconstruction in dynamic scenes using point-based fusion").
//
// One fuse() call, in this order (ids change only in steps 3 and 4, after every association):
//   1. association   every valid pixel (raw depth > 0 and a valid level-0 normal) of the pixel_stride
//                    grid (by default every pixel) is moved into the
//                    camera the index map was rendered from (IndexMap::T_world_cam: SurfelSlam
//                    renders it at the frame's tracked pose, so that this is the identity, or with
//                    associate_at_tracked_pose false gives the previous pose's; pixels outside that
//                    map then find no candidates) and projected into the index grid. Its
//                    candidates are the surfels of the scale x scale block of index pixels around the
//                    projection (the pixel's footprint), and only when none of those passes the
//                    gates, of a margin of search_margin_index_px around the block (the gates read
//                    the index map's copy of each candidate's normal and confidence: slam/index_map.h).
//                    A candidate passes the depth gate |z_surfel - z_measured| <= depth_gate_m(z)
//                    (along the index camera's ray: the map stores the surfel's depth in that camera)
//                    and the normal gate
//                    (angle <= association_normal_deg, world frame). The winner is a surfel not yet
//                    updated this frame if there is one, then the nearest to the ray (index-pixel
//                    distance of its centre), then the most confident. If the winner was already
//                    updated this frame the pixel is "covered": neither a second update (at most one
//                    per surfel per frame) nor a new surfel.
//   2. fusion        the winner takes the confidence-weighted average of position, normal
//                    (renormalised), colour and radius, confidence += w, last_seen = frame - unless the
//                    measurement's radius exceeds max_radius_growth x the surfel's: then only the
//                    confidence and last_seen change (a coarser view confirms but does not blur a finer
//                    surfel; ElasticFusion's rule). Gated candidates of that pixel that duplicate the
//                    winner (merge_* options) are merged into the more confident of the two.
//   3. cleaning      over the surfels seen in the candidate windows this frame, plus a bounded
//                    round-robin sweep of the pool for the lifetime rule: an unstable surfel older than
//                    unstable_lifetime_frames (since init_time) is removed; a surfel of a pixel's block
//                    lying in front of the measured surface by more than free_space_gate_factor depth
//                    gates (free-space violation) and not updated this frame is removed if unstable,
//                    or loses free_space_penalty confidence if stable; merged surfels are removed.
//                    Swap-removal from high ids to low.
//   4. creation      every unmatched valid pixel becomes a new surfel through
//                    SurfelPool::reserve_for_new (the full-pool policy: evictions and refusals are
//                    counted by the pool); when not all fit, the admitted ones are spread evenly over
//                    the image rather than taken from the top rows.
// The cost is that of the frame's pixels and their candidates, not of the pool size (except the
// pool's own eviction scan when it is full: slam/surfel_pool.h).
//
// Depth and normals used: positions and radii from the raw (cut-off) depth, as ElasticFusion does:
// fusion over many frames is the denoiser, and it keeps edges and small structures that the
// bilateral filter rounds off (fuse_raw_depth). Normals from the filtered depth, of pyramid level 1
// by default, because level-0 normals of Kinect-like depth at 320x240 are too noisy to gate on
// (normal_level, with the measurements).
//
// Confidence weight (ElasticFusion): w = exp(-gamma^2 / (2 sigma^2)), gamma = distance of the pixel
// from the principal point divided by that of the farthest image corner (0 at the centre, 1 at the
// corners), sigma = confidence_sigma: 1 at the centre, 0.25 in the corners for sigma 0.6.
// Radius (ElasticFusion): r = sqrt(2) z / f / |cos(incidence)|, the disc that covers the pixel's
// footprint on the surface; 1/|cos| capped at max_radius_incidence_factor.
//
// Memory: create() allocates everything, bytes(): 1 per index pixel (the state of the current
// frame), 4 per entry of the list of seen surfels (min(capacity, index pixels) plus
// lifetime_sweep_per_frame), one bit per id of the lifetime sweep, 8 per working pixel (unmatched
// pixels, confidence weights), 108 per working column (one row of measurements and their gate
// codes); 1.1 MB at 320x240
// and index map scale 1 with the default sweep, whatever the pool's capacity. fuse() never touches
// the heap.
// Threads: one SurfelFusion per mapping thread; fuse() is not reentrant.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>

#include <Eigen/Core>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/options.h"
#include "core/result.h"
#include "core/se3.h"
#include "kernels/label_update.h"
#include "slam/index_map.h"
#include "slam/surfel_pool.h"

namespace ef::slam {

class Preprocessor;

struct FusionOptions {
  // Confidence at which a surfel is stable (dimensionless, > 0): used for tracking, never evicted,
  // not removed by the lifetime rule. ElasticFusion: 10.
  float stable_confidence = 10.0f;

  // Confidence weight: sigma of the Gaussian of the normalised radial distance (dimensionless, > 0).
  // ElasticFusion: 0.6.
  float confidence_sigma = 0.6f;

  // Depth gate, metres: |z_surfel - z_measured| <= association_depth_base_m +
  // association_depth_quadratic * z^2 (z the measured depth, metres). Follows the Kinect's axial
  // noise, which grows with z^2 (1.9 mm at 1 m, 14 mm at 3 m; quantisation steps 3 mm / 26 mm):
  // defaults give 1.8 cm at 1 m, 4.2 cm at 2 m, 8.2 cm at 3 m, 13.8 cm at 4 m.
  float association_depth_base_m = 0.01f;
  float association_depth_quadratic = 0.008f;  // metres per metre^2
  // Candidates: the scale x scale block of index pixels nearest to the pixel's projection (one
  // working pixel's footprint, ElasticFusion's 4x4); when no surfel of the block passes the gates,
  // also a margin of this many index pixels around it (0..4). Only block surfels can be free-space
  // violations. Why 1 (a 6x6 window at scale 4, 1.5 working pixels): surfels made at one pose are not
  // one per pixel seen from the next, and a pixel whose block happens to hold none makes a duplicate
  // about half a pixel from an existing surfel. Measured (default options otherwise, at the time
  // scale 4): a noise-free office pair 2 cm / 1.2 degrees apart makes new surfels for 11.6% of the
  // pixels with margin 0, 3.8% with 1, 3.2% with 2 (~2.4% are newly seen surface); after 30 noisy
  // office frames the pool holds 176k / 122k / 108k surfels for the same ~52k stable ones. The
  // price: pixels whose candidates were all updated already this frame ("covered": 0.4% / 13% / 19%
  // of the pixels at frame 29) add nothing; the map densifies only where its surfels are more than
  // 1.5 pixels apart in the view.
  // A pixel whose block has a passing candidate that was already updated is covered without a look
  // at the margin for one not yet updated. Looking there too (until this was measured) found one for
  // about 2% of the valid pixels, and cost the 7-Scenes run (1000 frames, 320x240, scale 2, side by
  // side) 2.2 ms of fuse per frame (13.4 against 11.2 ms) for the same map and accuracy: ATE 2.74
  // against 2.76 cm, 391k against 384k surfels, semantic Table I class average 93.6 against 93.7.
  int search_margin_index_px = 1;
  // Normal gate: largest angle between the surfel's and the measured normal, degrees (0, 90].
  // 30 = ElasticFusion's 0.5 rad. Measured over 30 noisy office frames (defaults otherwise), pixels
  // unmatched because of the normal gate at frame 29: 2.5% at 20 degrees, 1.1% at 30.
  float association_normal_deg = 30.0f;

  // Radius: 1/|cos(incidence)| is capped at this (>= 1): a grazing view does not make huge discs.
  // 4 = the radius stops growing beyond ~75.5 degrees of incidence.
  float max_radius_incidence_factor = 4.0f;
  // A measurement whose radius exceeds this factor times the surfel's only adds confidence and
  // updates last_seen (dimensionless, >= 1). ElasticFusion / Keller: 1.5.
  float max_radius_growth = 1.5f;

  // Unstable surfels (confidence < stable_confidence) older than this many frames since init_time
  // are removed (frames, >= 1). 60 frames = 2 s at 30 Hz: a surface seen throughout that time gains
  // at least 60 x 0.25 = 15 > 10 confidence even in the image corners.
  int32_t unstable_lifetime_frames = 60;
  // Surfels not seen this frame are checked for the lifetime rule by a round-robin sweep of this
  // many ids per frame (>= 0; 0 = only surfels seen in the candidate windows are checked): a
  // bounded sequential scan of two columns; a 1,000,000-surfel pool is swept in 62 frames.
  int32_t lifetime_sweep_per_frame = 16384;

  // Free-space violation: a surfel whose depth is smaller than the measured depth by more than
  // free_space_gate_factor depth gates (at that depth) lies in space the sensor sees through.
  // Dimensionless, >= 1. 2: 3.6 cm at 1 m, 16 cm at 3 m.
  float free_space_gate_factor = 2.0f;
  // Confidence taken from a stable violating surfel (dimensionless, >= 0): about one observation at
  // the image centre, so a surface that disappeared (moved object) fades out over as many frames as
  // it took to build, while one wrong pixel at an edge does little.
  float free_space_penalty = 1.0f;

  // Duplicate merging, among the candidates that passed the gates for the pixel a surfel was fused
  // at: a candidate merges into it (or it into the candidate, whichever is more confident) when their
  // centres are within merge_max_distance_px working pixels of each other both in the index grid
  // and across the normal (metres: that many pixels' footprint z / f at their depth), within one
  // depth gate along the normal, their normals within merge_normal_deg degrees and radii within
  // merge_max_radius_ratio. 0.5 px: surfels of neighbouring pixels (1 px apart) never merge; two
  // surfels closer than half a pixel cannot be told apart at this resolution. 0 disables merging.
  float merge_max_distance_px = 0.5f;
  float merge_normal_deg = 15.0f;
  float merge_max_radius_ratio = 1.5f;

  // true (default): positions and radii from the raw (cut-off) depth, normals from the filtered depth
  // (ElasticFusion). false: positions from the bilateral-filtered depth too.
  bool fuse_raw_depth = true;
  // Pyramid level whose normals are fused and gated (0 or 1; must exist in the Preprocessor). Level
  // 1 (half resolution, from a depth averaged over 4x4 pixels) is the default because level-0
  // normals of Kinect-like depth at 320x240 are too noisy to gate on: measured on the noisy
  // synthetic office against noise-free normals, median / 90th percentile error 19 / 40 degrees at
  // 2.5-3.5 m on level 0 but 5 / 12 degrees on level 1; after 30 frames the pool holds 340k surfels
  // of which 23k stable with level 0, 122k of which 53k stable with level 1. A pixel takes the
  // level-1 normal of its 2x2 block when that block's depth is within the depth gate of its own
  // (same surface), else its own level-0 normal; it needs a valid level-0 normal either way (which
  // excludes depth edges). The price: creases are blurred over 2 pixels.
  int normal_level = 1;

  // At index-map scale 1 and search_margin_index_px 1 (the defaults), the index map's tests of each
  // pixel's 3x3 candidates (occupancy, depth and free-space gates, the normal gate on the map's copy
  // of the normal) are evaluated for a whole row at once by kernels/fusion_gates (SIMD), and only
  // this frame's own state (surfels already updated or merged) is tested per candidate. false: every
  // candidate of every pixel is tested on its own (visit_cell). The results are the same either way,
  // bit for bit (tests/slam/test_surfel_fusion.cpp compares them); true is faster (docs/results.md,
  // issue 31). Pixels whose projection leaves their own index pixel (an index map rendered at another
  // pose) or that lie on the image border take the per-candidate path in both cases.
  bool row_gates = true;

  // Pixels fused: every pixel_stride-th pixel of every pixel_stride-th row (1 or 2), the others left
  // out of association and creation. At 2 each fused pixel stands for its 2x2 cell: where the cell is
  // one surface (fusion_math::cell_depth) it is measured at the cell's mean depth on the ray through
  // the cell's centre, and its colour is the cell's mean (sampling one pixel's texture at half its
  // rate made the predicted intensity alias); its normal is the level-1 normal of the same block
  // (normal_level 1); its disc 1.3x one pixel's (fusion_math::kStrideTwoRadiusScale: at 1x, a disc
  // that only just reaches its cell's corners, the stable model had holes where the camera turned
  // into new surface and lost a Kinect-camera scan). Tracking and the prediction keep the full
  // working resolution. 1 = every pixel (ElasticFusion). Measured side by side (docs/results.md,
  // issue 31): on the real 7-Scenes kitchen, one idle core, the four SLAM stages 14.0-14.5 -> 8.4-8.5
  // ms per frame at 2 with one pixel's disc (fuse and the renders work per surfel; the 1.3x disc adds
  // about 0.25 ms, larger discs to draw) with 131k surfels instead of 371k covering the same
  // picture, ATE 2.71 cm (every pixel 2.69); the synthetic 2000-frame loop more accurate (the cell's
  // mean halves the depth noise), the eleven inspecting scans of Table I and the eight Kinect-camera
  // scans as accurate or more (seed 5005 needed the tracker's lost_max_condition at 4e4:
  // slam/tracker.h). The price: the stable model covers fewer pixels, so a registration against a
  // small inactive model needs more of it in view (a loop check from further into the revisit).
  int pixel_stride = 2;

  // The keys `run` offers (section mapping): fusion_stride.
  static const opt::Table<FusionOptions>& table();
  // An error naming the first field out of range.
  Status validate() const;
  // One line per field with its unit, for logs.
  std::string describe() const;
};

// What the last fuse() did. Pixel counts are working-resolution pixels (of the pixel_stride grid).
struct FusionStats {
  int64_t valid_pixels = 0;     // raw depth > 0 and a valid normal
  int64_t fused_pixels = 0;     // fused into an existing surfel (averaged or confidence only)
  int64_t confirmed_only = 0;   // of fused_pixels: radius rule, only confidence and last_seen changed
  int64_t covered_pixels = 0;   // the only passing candidates were already updated this frame
  int64_t new_surfels = 0;      // appended
  // Why pixels were unmatched (the three sum to new_surfels + refused):
  int64_t unmatched_empty = 0;  // no candidate in the window (or no index map / behind its camera)
  int64_t unmatched_depth = 0;  // candidates, none within the depth gate
  int64_t unmatched_normal = 0; // candidates within the depth gate, none within the normal gate
  int64_t refused = 0;          // unmatched pixels not created: pool full (also counted by the pool)
  int64_t evicted = 0;          // surfels the pool evicted this frame to make room
  int64_t removed_stale = 0;    // unstable beyond unstable_lifetime_frames
  int64_t removed_free_space = 0;
  int64_t demoted_free_space = 0;  // stable surfels that lost confidence to a free-space violation
  int64_t merged = 0;           // surfels merged into another (and removed)
  int64_t seen_surfels = 0;     // distinct surfels found in the candidate windows
  int64_t invalid_index_ids = 0;  // index map ids >= pool size (a stale map: should stay 0)
  int64_t row_gated_pixels = 0;   // of valid_pixels, associated through the row pass (row_gates)
  double associate_ms = 0;      // steps 1-2
  double clean_ms = 0;          // step 3
  double create_ms = 0;         // step 4
  double total_ms = 0;
};

// Per-surfel and per-pixel maths, written once: the scalar loop of fuse() uses these and any SIMD
// variant must too (docs/architecture.md: "per-element maths written once").
namespace fusion_math {

// ElasticFusion's confidence weight from the squared normalised radial distance gamma^2 (0 at the
// principal point, 1 at the farthest corner); inv_two_sigma2 = 1 / (2 sigma^2).
inline float confidence_weight(float gamma2, float inv_two_sigma2) { return std::exp(-gamma2 * inv_two_sigma2); }

// The depth gate at depth z (metres), metres.
inline float depth_gate_m(float z, float base_m, float quadratic) { return base_m + quadratic * z * z; }

// A surfel fused at FusionOptions::pixel_stride 2 stands for its 2x2 cell; its disc radius is this
// times one pixel's (surfel_radius_m), so that the discs of neighbouring cells overlap when drawn
// from another view (at 1x they only just reach the cell's corners). Measured on the Kinect-camera
// inspecting scans (docs/results.md, issue 31): at 1x the stable model left holes where the camera
// turned into new surface and seed 8 lost its track (273 of 300 frames; 1.2x too); 1.3x held all
// eight (0 lost); 1.41x-2x slid on seed 3 (ATE 73-93 mm over 80 frames, in a corner where ICP is
// blind and the photometric term decides).
inline constexpr float kStrideTwoRadiusScale = 1.3f;

// Disc radius (metres) of a measurement at depth z (metres) seen with |cos(incidence)| = cos_abs,
// focal length f (pixels): sqrt(2) z / f / cos, with 1/cos capped at max_factor.
// Written as one division of a clamped value, not a division in one arm of a select, so that a loop
// over pixels has no branch (GCC sinks such a division into a branch and then does not vectorise);
// 1 / (1 / max_factor) is max_factor exactly when it is a power of two, as the default 4.
inline float surfel_radius_m(float z, float cos_abs, float f, float max_factor) {
  const float inv_cos = 1.0f / std::max(cos_abs, 1.0f / max_factor);
  return 1.41421356f * z / f * inv_cos;
}

// The depth a fused pixel stands for at pixel_stride 2, and where: its 2x2 cell (the pixel d, the one
// to its right d1, below d2, below right d3; metres, 0 = invalid) is one surface when all four are
// valid and within `gate` (metres) of d; then the cell's mean depth, measured at the cell's centre
// (offset 0.5 pixel right and down), else the pixel's own depth at the pixel (offset 0). The
// mean of four Kinect-like depths halves their noise: measured on the synthetic 2000-frame loop, ATE
// 0.90 cm with the pixel's depth, 0.21 cm with the cell's (every pixel: 0.55 cm). Callers pass
// gate = depth_gate_m(d) and d1..d3 = 0 outside the image.
struct CellDepth {
  float depth;   // metres
  float offset;  // pixels right and down of the fused pixel
};
inline CellDepth cell_depth(float d, float d1, float d2, float d3, float gate) {
  const float nearest = std::min(std::min(d, d1), std::min(d2, d3));
  const float spread = std::max(std::max(std::fabs(d1 - d), std::fabs(d2 - d)), std::fabs(d3 - d));
  const float mean = 0.25f * ((d + d1) + (d2 + d3));
  const bool one_surface = (nearest > 0.0f) & (spread <= gate);
  return CellDepth{one_surface ? mean : d, one_surface ? 0.5f : 0.0f};
}

// The quantity averaged into a surfel: world-frame position (metres), unit normal, radius (metres),
// colour (0..255 per channel) and the weight of this observation.
struct Sample {
  Eigen::Vector3f p, n;
  float radius = 0;
  float r = 0, g = 0, b = 0;
  float weight = 0;
};

inline uint8_t to_u8(float c) {
  const float v = c + 0.5f;
  return v <= 0.0f ? uint8_t{0} : (v >= 255.0f ? uint8_t{255} : static_cast<uint8_t>(v));
}

// The confidence-weighted average of surfel `id` (confidence c) and `s` (weight w):
// x <- (c x + w x_s) / (c + w) for position, normal (then renormalised), colour and radius; the
// confidence becomes c + w. Writes the columns of `pool`; confidence and times are the caller's.
inline void average_into(SurfelPool& pool, int64_t id, const Sample& s) {
  const float c = pool.confidence()[id];
  const float inv = 1.0f / (c + s.weight);
  const float a = c * inv, b = s.weight * inv;
  const SurfelPool& in = pool;  // reads through the const columns (slam/surfel_pool.h: block bounds)
  pool.set_position(id, a * in.x()[id] + b * s.p.x(), a * in.y()[id] + b * s.p.y(), a * in.z()[id] + b * s.p.z());
  Eigen::Vector3f n(a * pool.nx()[id] + b * s.n.x(), a * pool.ny()[id] + b * s.n.y(), a * pool.nz()[id] + b * s.n.z());
  const float len = n.norm();
  // One division and three products rather than three divisions (this runs for every fused pixel).
  // Opposite normals cannot pass the gates; keep the old one if they did.
  if (len > 1e-6f) n *= 1.0f / len;
  else n = Eigen::Vector3f(pool.nx()[id], pool.ny()[id], pool.nz()[id]);
  pool.nx()[id] = n.x();
  pool.ny()[id] = n.y();
  pool.nz()[id] = n.z();
  pool.radius()[id] = a * pool.radius()[id] + b * s.radius;
  const uint32_t col = pool.color()[id];
  pool.color()[id] = pack_rgb(to_u8(a * unpack_r(col) + b * s.r), to_u8(a * unpack_g(col) + b * s.g),
                              to_u8(a * unpack_b(col) + b * s.b));
}

// ElasticFusion's update of surfel `id` by one measurement at frame `frame`: the average above when
// s.radius <= max_radius_growth x the surfel's radius, then (always) confidence += weight and
// last_seen = frame. Returns whether the geometry was averaged.
inline bool fuse_sample(SurfelPool& pool, int64_t id, const Sample& s, float max_radius_growth, int32_t frame) {
  const bool average = s.radius <= max_radius_growth * pool.radius()[id];
  if (average) average_into(pool, id, s);
  pool.confidence()[id] += s.weight;
  pool.set_last_seen(id, frame);
  return average;
}

// The surfel `id` as a Sample weighted by its confidence (for merging).
inline Sample sample_of(const SurfelPool& pool, int64_t id) {
  Sample s;
  s.p = Eigen::Vector3f(pool.x()[id], pool.y()[id], pool.z()[id]);
  s.n = Eigen::Vector3f(pool.nx()[id], pool.ny()[id], pool.nz()[id]);
  s.radius = pool.radius()[id];
  const uint32_t c = pool.color()[id];
  s.r = unpack_r(c);
  s.g = unpack_g(c);
  s.b = unpack_b(c);
  s.weight = pool.confidence()[id];
  return s;
}

// Merges surfel `other` into `keep`: confidence-weighted average, confidences summed (both were
// evidence of the same surface), the earlier init_time and the later last_seen. `other` is left
// for the caller to remove. Labels: the product of the two distributions (kernels::label_merge),
// since both surfels gathered independent evidence of the same surface.
inline void merge_into(SurfelPool& pool, int64_t keep, int64_t other) {
  const Sample s = sample_of(pool, other);
  average_into(pool, keep, s);
  kernels::label_merge(pool.labels() + keep * SurfelPool::kLabelBytesPerSurfel,
                       pool.labels() + other * SurfelPool::kLabelBytesPerSurfel);
  pool.confidence()[keep] += s.weight;
  if (pool.init_time()[other] < pool.init_time()[keep]) pool.init_time()[keep] = pool.init_time()[other];
  const int32_t* seen = std::as_const(pool).last_seen();
  if (seen[other] > seen[keep]) pool.set_last_seen(keep, seen[other]);
}

}  // namespace fusion_math

class SurfelFusion {
 public:
  // working: intrinsics of the frames fuse() gets (Preprocessor level 0). index_map_scale: the
  // IndexMap::scale the predictor renders with (1..4). pool_capacity: the capacity of the pools
  // fuse() will write (per-surfel scratch is sized to it). Errors (kInvalidArgument): invalid
  // options, intrinsics, scale or capacity.
  static Result<SurfelFusion> create(const Intrinsics& working, int index_map_scale, int64_t pool_capacity,
                                     const FusionOptions& options = {});

  SurfelFusion(SurfelFusion&&) noexcept = default;
  SurfelFusion& operator=(SurfelFusion&&) noexcept = default;

  // Fuses the preprocessed frame `frame` (working resolution), seen from T_world_cam (camera to
  // world), into `pool`, associating through `index` (rendered from `pool` at index.T_world_cam, a
  // nearby pose, before any removal since). `color`: sRGB of the working size, or empty (new surfels
  // are then mid grey and colours are not updated). An empty index map (nothing rendered yet) means
  // no candidates: every valid pixel becomes a new surfel. frame_index: stored as init_time /
  // last_seen and compared with them by the lifetime rule.
  // Errors (kInvalidArgument): sizes that do not match create(), a wrong index-map scale, a pool
  // larger than the capacity given at create(), a Preprocessor without options().normal_level,
  // null pointers. No heap allocation.
  Status fuse(const Preprocessor& frame, ImageView<const Rgb8> color, const SE3& T_world_cam, const IndexMap& index,
              int32_t frame_index, SurfelPool* pool, FusionStats* stats);

  const FusionOptions& options() const { return options_; }
  const Intrinsics& intrinsics() const { return K_; }
  int index_map_scale() const { return scale_; }
  // Where the lifetime sweep goes on next frame: the one thing fusion carries from frame to frame
  // (a checkpoint saves and restores it).
  int64_t sweep_cursor() const { return sweep_cursor_; }
  void set_sweep_cursor(int64_t id) { sweep_cursor_ = id; }
  // Bytes allocated by create().
  std::size_t bytes() const { return bytes_; }
  // Bytes create() allocates for a working image of width x height, an index map of that scale and
  // a pool of that capacity (the formula under "Memory" above).
  static std::size_t bytes_for(int width, int height, int index_map_scale, int64_t pool_capacity,
                               const FusionOptions& options);

 private:
  SurfelFusion() = default;

  // State of the current frame, per index pixel: a surfel's centre lands in at most one index
  // pixel, so the flags of the pixel are those of its surfel, kept in an array of the index map's
  // size (read and written row by row, like the map) rather than one indexed by scattered surfel ids.
  enum StateFlag : uint8_t { kSeen = 1, kUpdated = 2, kViolated = 4, kMerged = 8 };

  struct PixelContext;  // one pixel's measurement, in the frames the loop needs (surfel_fusion.cpp)
  struct FrameContext;  // per-frame transforms and gates
  struct WindowScan;    // one pixel's candidates

  void begin_frame();
  uint8_t flags(int32_t cell) const { return cell_state_[cell]; }
  void set_flag(int32_t cell, uint8_t f) { cell_state_[cell] = static_cast<uint8_t>(cell_state_[cell] | f); }
  // Marks the surfel of index pixel `cell` seen (and lists the pixel) the first time this frame.
  void see(int32_t cell);

  template <bool kCoarse>
  bool measure(float x, float y, float d, const float* n0, const float* n1, float cd, Eigen::Vector3f* v,
               Eigen::Vector3f* n_c) const;
  bool make_pixel(const FrameContext& fc, int x, int y, PixelContext* px) const;
  // The depth pixel (x, y) fuses and the offset of where it is measured (fusion_math::cell_depth at
  // pixel_stride 2; the pixel's own at 1).
  float fused_depth(const FrameContext& fc, int x, int y, float* offset) const;
  void prepare_row(const FrameContext& fc, int y);
  template <bool kCoarse>
  void prepare_row(const FrameContext& fc, int y);
  void associate(const FrameContext& fc, const IndexMap& index, SurfelPool& pool, int32_t frame_index,
                 FusionStats& st);
  void visit_cell(const FrameContext& fc, const IndexMap& index, const SurfelPool& pool, const PixelContext& px, int bx,
                  int by, bool in_base, WindowScan* ws, FusionStats& st);
  void scan_window(const FrameContext& fc, const IndexMap& index, const SurfelPool& pool, const PixelContext& px,
                   WindowScan* ws, FusionStats& st);
  void scan_unit_window(const FrameContext& fc, const IndexMap& index, const SurfelPool& pool, const PixelContext& px,
                        WindowScan* ws, FusionStats& st);
  void scan_gated(const IndexMap& index, const SurfelPool& pool, const PixelContext& px, uint32_t code,
                  WindowScan* ws);
  void merge_duplicates(SurfelPool& pool, const WindowScan& ws, float z, FusionStats& st);
  void clean(const IndexMap& index, SurfelPool& pool, int32_t frame_index, FusionStats& st);
  void create_new(const FrameContext& fc, SurfelPool& pool, int32_t frame_index, FusionStats& st);
  void sample_geometry(const FrameContext& fc, const Eigen::Vector3f& v, const Eigen::Vector3f& n_c, Eigen::Vector3f* p,
                       float* radius) const;
  fusion_math::Sample sample_at(const FrameContext& fc, const PixelContext& px) const;
  // The sample of pixel px at world position p with that radius: its normal, colour and weight.
  fusion_math::Sample sample_from(const PixelContext& px, const Eigen::Vector3f& p, float radius) const;
  bool mergeable(const SurfelPool& pool, int64_t a, int64_t b, float z) const;
  // The depth gate at depth z (metres), metres.
  float depth_gate(float z) const {
    return fusion_math::depth_gate_m(z, options_.association_depth_base_m, options_.association_depth_quadratic);
  }

  FusionOptions options_;
  Intrinsics K_;
  int scale_ = 4;
  int64_t capacity_ = 0;
  std::size_t bytes_ = 0;
  float cos_normal_gate_ = 0, cos_merge_gate_ = 0, focal_ = 0;
  float radius_scale_ = 1;  // disc radius over one pixel's: fusion_math::kStrideTwoRadiusScale at stride 2
  ImageView<const Rgb8> color_;            // the current frame's colour (fuse() only)

  std::unique_ptr<uint8_t[]> cell_state_;  // StateFlag bits per index pixel, cleared by begin_frame()
  int64_t cells_ = 0;                      // index pixels
  std::unique_ptr<int32_t[]> seen_;        // index pixels seen this frame, then the ids to remove
  int64_t seen_capacity_ = 0, seen_count_ = 0;
  // One bit per id of this frame's lifetime sweep: set when the seen surfels already decided it.
  std::unique_ptr<uint64_t[]> sweep_decided_;
  // One row of measurements (prepare_row), kRowFields arrays of width floats: validity (1 or 0), the
  // vertex, camera and world normals, the vertex in the index map's camera, its index-grid projection
  // and depth gate, the world position and disc radius of its sample, and the coarse level's normal
  // and depth spread to the pixels.
  enum RowField : int {
    kRowValid, kRowVx, kRowVy, kRowVz, kRowNcx, kRowNcy, kRowNcz, kRowNwx, kRowNwy, kRowNwz,
    kRowPix, kRowPiy, kRowPiz, kRowXi, kRowYi, kRowGate, kRowPwx, kRowPwy, kRowPwz, kRowRadius,
    kRowC1x, kRowC1y, kRowC1z, kRowCd,  // input: the coarse normal and depth of each pixel's block
    kRowDepth, kRowOffset,              // input at pixel_stride 2: fusion_math::cell_depth
    kRowFields
  };
  std::unique_ptr<float[]> row_;
  float* row_field(int field) const { return row_.get() + static_cast<std::size_t>(field) * K_.width; }
  // The static gates of each pixel of the current row (kernels/fusion_gates.h), index map scale 1.
  std::unique_ptr<uint32_t[]> gate_code_;
  std::unique_ptr<int32_t[]> unmatched_;   // pixel indices y * width + x of unmatched valid pixels
  int64_t unmatched_count_ = 0;
  Image<float> weight_;                    // confidence weight per working pixel
  int64_t sweep_cursor_ = 0;               // next id of the lifetime sweep
};

}  // namespace ef::slam
