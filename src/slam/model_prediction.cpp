// Model prediction: index map and tracking maps rendered from the surfel pool; see model_prediction.h.
#include "slam/model_prediction.h"

#include "core/stopwatch.h"
#include "kernels/gradient_fill_row.h"
#include "slam/depth_pyramid.h"
#include "slam/preprocess.h"
#include "slam/vertex_normal.h"

#include "kernels/splat_disc.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <sstream>

namespace ef::slam {

namespace {

constexpr int kMinCoarsestSize = 8;  // pixels, both dimensions (as the Preprocessor and the Tracker)
constexpr float kMaxSplatCapPx = 64.0f;
// Surfels per block of the pass over the pool: a block's transformed columns (5 x 4 bytes x 256 =
// 5 KiB, two blocks on the stack) and its discs (11 KiB) stay in L1 between the vectorised loops and
// the scalar ones.
constexpr int kBlock = SurfelPool::kBoundsBlock;  // surfels per block of work: the pool's bounds blocks
constexpr float kInf = std::numeric_limits<float>::infinity();

using Clock = SteadyClock;

// Grey level 0..255 of a packed sRGB colour (weights of slam/preprocess.h).
inline float grey(uint32_t c) {
  return grey_level(unpack_r(c), unpack_g(c), unpack_b(c));
}

}  // namespace

// What one predict() call needs per surfel, as plain floats: the world-to-camera transform, the
// camera centre, and the tracking thresholds.
struct ModelPredictor::Pose {
  float r[9];          // R_cw row-major: camera = R_cw * world + t_cw
  float t[3];          // t_cw, metres
  float c[3];          // camera centre in the world frame, metres
  float min_confidence;
  int32_t oldest_frame;  // surfels with last_seen < this are outside the active window
  int32_t seen_before;   // and those with last_seen >= this are left out too (the inactive model)
  int32_t index_oldest = INT32_MIN;  // the index map's own window: surfels last seen before are left out
  bool draw_index = true;            // false: the index map is not drawn (IndexMapDraw::kSkip)
};

const opt::Table<PredictionOptions>& PredictionOptions::table() {
  static const opt::Table<PredictionOptions> t = {
      {"index_map_scale", "index_map_scale", "", &PredictionOptions::index_map_scale, "index cells per working pixel and axis",
       opt::between(1, kMaxIndexScale), "4 = ElasticFusion's, slower for the same accuracy at 320x240 (docs/results.md)"},
      {"active_window_frames", "", "", &PredictionOptions::active_window_frames, "frames",
       opt::between(1, 1e6).or_value(0, "no limit"), "tracking sees only surfels seen this recently (ElasticFusion: 200)"},
  };
  return t;
}

Status PredictionOptions::validate() const {
  EF_RETURN_IF_ERROR(opt::check_table(*this, table(), "prediction"));
  const auto bad = [](const std::string& field, const std::string& why) {
    return error(ErrorCode::kInvalidArgument, "PredictionOptions." + field + " " + why);
  };
  if (!(stable_confidence >= 0.0f) || !std::isfinite(stable_confidence))
    return bad("stable_confidence", "must be finite and >= 0");
  if (!(max_splat_radius_px > 0.0f && max_splat_radius_px <= kMaxSplatCapPx))
    return bad("max_splat_radius_px", "must be in (0, 64] pixels");
  if (!(near_clip_m > 0.0f) || !std::isfinite(near_clip_m)) return bad("near_clip_m", "must be > 0 metres");
  if (!(far_clip_m > near_clip_m) || !std::isfinite(far_clip_m))
    return bad("far_clip_m", "must be finite and > near_clip_m");
  if (!(splat_tie_depth_fraction >= 0.0f && splat_tie_depth_fraction <= 0.1f))
    return bad("splat_tie_depth_fraction", "must be in [0, 0.1]");
  if (!(pyramid_depth_threshold_m > 0.0f) || !std::isfinite(pyramid_depth_threshold_m))
    return bad("pyramid_depth_threshold_m", "must be > 0 metres");
  if (!(normal_min_grazing_deg > 0.0f && normal_min_grazing_deg < 90.0f))
    return bad("normal_min_grazing_deg", "must be in (0, 90) degrees");
  return Status::success();
}

std::string PredictionOptions::describe() const {
  std::ostringstream s;
  s << "index_map_scale " << index_map_scale << "  # index pixels per working pixel, each axis\n"
    << "stable_confidence " << stable_confidence << "  # surfels at least this confident are tracked against\n"
    << "active_window_frames " << active_window_frames << " frames  # 0 = no limit\n"
    << "max_splat_radius_px " << max_splat_radius_px << " px  # disc footprint cap, working pixels\n"
    << "near_clip_m " << near_clip_m << " m\n"
    << "far_clip_m " << far_clip_m << " m\n"
    << "splat_tie_depth_fraction " << splat_tie_depth_fraction << "  # of depth: discs within it are ranked by centre distance\n"
    << "pyramid_depth_threshold_m " << pyramid_depth_threshold_m << " m  # coarse levels: near-surface test\n"
    << "normal_min_grazing_deg " << normal_min_grazing_deg << " deg  # coarse normals: steeper steps are edges\n";
  return s.str();
}

Result<ModelPredictor> ModelPredictor::create(const Intrinsics& working, int levels, const PredictionOptions& options) {
  EF_RETURN_IF_ERROR(options.validate());
  if (!working.valid()) return error(ErrorCode::kInvalidArgument, "ModelPredictor: invalid working intrinsics");
  if (levels < 1 || levels > kTrackerMaxLevels)
    return error(ErrorCode::kInvalidArgument,
                 "ModelPredictor: levels " + std::to_string(levels) + " is outside 1.." + std::to_string(kTrackerMaxLevels));
  const Intrinsics coarsest = working.pyramid_level(levels - 1);
  if (coarsest.width < kMinCoarsestSize || coarsest.height < kMinCoarsestSize)
    return error(ErrorCode::kInvalidArgument, "ModelPredictor: " + std::to_string(working.width) + "x" +
                                                  std::to_string(working.height) + " is too small for " +
                                                  std::to_string(levels) + " levels (coarsest must be at least 8x8)");
  ModelPredictor p;
  p.options_ = options;
  p.levels_ = levels;
  for (int l = 0; l < levels; ++l) {
    PredictedLevel& lv = p.level_[l];
    lv.intrinsics = working.pyramid_level(l);
    const int w = lv.intrinsics.width, h = lv.intrinsics.height;
    lv.depth.allocate(w, h);
    lv.vertex.allocate(w, h);
    lv.normal.allocate(w, h);
    lv.intensity.allocate(w, h);
    lv.grad_x.allocate(w, h);
    lv.grad_y.allocate(w, h);
  }
  const int w = working.width, h = working.height, s = options.index_map_scale;
  IndexMap& im = p.index_map_;
  im.scale = s;
  im.intrinsics = working.scaled_to(w * s, h * s);
  im.id.allocate(w * s, h * s);
  im.depth.allocate(w * s, h * s);
  im.surface.allocate(w * s, h * s);
  im.id.fill(-1);
  p.winner_.allocate(w, h);
  p.winner_.fill(-1);
  p.color_.allocate(w, h);
  p.ray_x_.allocate(w, 1);
  p.row_scratch_.allocate(w, 1);
  p.ray_y_.allocate(h, 1);
  for (int x = 0; x < w; ++x) p.ray_x_(x, 0) = (static_cast<float>(x) - working.cx) / working.fx;
  for (int y = 0; y < h; ++y) p.ray_y_(y, 0) = (static_cast<float>(y) - working.cy) / working.fy;
  return p;
}

namespace {
// Per pixel of every level: depth, vertex, normal, intensity and the two gradients.
constexpr std::size_t kLevelBytesPerPixel = sizeof(float) + 2 * sizeof(Eigen::Vector3f) + 3 * sizeof(float);
}  // namespace

std::size_t ModelPredictor::bytes_for(int width, int height, int levels, const PredictionOptions& options) {
  const auto px = [](int w, int h) { return static_cast<std::size_t>(w > 0 ? w : 0) * static_cast<std::size_t>(h > 0 ? h : 0); };
  std::size_t b = 0;
  int w = width, h = height;
  for (int l = 0; l < levels; ++l) {  // Intrinsics::pyramid_level halves, rounding down
    b += px(w, h) * kLevelBytesPerPixel;
    w /= 2;
    h /= 2;
  }
  const int s = options.index_map_scale;
  b += px(width * s, height * s) * (sizeof(int32_t) + sizeof(float) + sizeof(IndexSurface));  // index map
  b += px(width, height) * (sizeof(int32_t) + sizeof(Rgb8));             // winners, colours
  b += (2 * static_cast<std::size_t>(width) + static_cast<std::size_t>(height)) * sizeof(float);  // rays, scratch row
  return b;
}

std::size_t ModelPredictor::bytes() const {
  return bytes_for(level_[0].intrinsics.width, level_[0].intrinsics.height, levels_, options_);
}

PyramidView ModelPredictor::pyramid_view() const {
  PyramidView view;
  view.levels = levels_;
  for (int l = 0; l < levels_; ++l) {
    const PredictedLevel& lv = level_[l];
    TrackerLevelView& v = view.level[l];
    v.intrinsics = lv.intrinsics;
    v.vertex = lv.vertex.view();
    v.normal = lv.normal.view();
    v.intensity = lv.intensity.view();
    v.grad_x = lv.grad_x.view();
    v.grad_y = lv.grad_y.view();
  }
  return view;
}

Status ModelPredictor::predict(const SurfelPool& pool, const SE3& T_world_cam, int32_t frame_index) {
  return predict(pool, T_world_cam, frame_index, options_.stable_confidence);
}

ModelPredictor::Pose ModelPredictor::make_pose(const SE3& T_world_cam, float min_confidence, int32_t oldest_frame,
                                               int32_t seen_before) {
  Pose pose;
  const SE3 T_cw = T_world_cam.inverse();
  const Eigen::Matrix3d R = T_cw.rotation_matrix();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) pose.r[3 * i + j] = static_cast<float>(R(i, j));
    pose.t[i] = static_cast<float>(T_cw.translation()(i));
    pose.c[i] = static_cast<float>(T_world_cam.translation()(i));
  }
  pose.min_confidence = min_confidence;
  pose.oldest_frame = oldest_frame;
  pose.seen_before = seen_before;
  return pose;
}

Status ModelPredictor::predict(const SurfelPool& pool, const SE3& T_world_cam, int32_t frame_index,
                               float tracking_min_confidence, IndexMapDraw index) {
  // In 64 bits: frame_index - window may be below INT32_MIN.
  const int64_t oldest =
      options_.active_window_frames == 0 ? INT32_MIN : static_cast<int64_t>(frame_index) - options_.active_window_frames;
  return predict_seen(pool, T_world_cam, tracking_min_confidence,
                      static_cast<int32_t>(std::max<int64_t>(oldest, INT32_MIN)), INT32_MAX, index);
}

Status ModelPredictor::predict_inactive(const SurfelPool& pool, const SE3& T_world_cam, int32_t seen_before,
                                        float tracking_min_confidence) {
  return predict_seen(pool, T_world_cam, tracking_min_confidence, INT32_MIN, seen_before, IndexMapDraw::kDraw);
}

Status ModelPredictor::predict_seen(const SurfelPool& pool, const SE3& T_world_cam, float tracking_min_confidence,
                                    int32_t oldest, int32_t seen_before, IndexMapDraw index) {
  if (!(tracking_min_confidence >= 0.0f) || !std::isfinite(tracking_min_confidence))
    return error(ErrorCode::kInvalidArgument, "ModelPredictor::predict: tracking_min_confidence " +
                                                  std::to_string(tracking_min_confidence) + " must be finite and >= 0");
  Clock::time_point t = Clock::now();
  const Clock::time_point start = t;
  Pose pose = make_pose(T_world_cam, tracking_min_confidence, oldest, seen_before);
  pose.draw_index = index == IndexMapDraw::kDraw;

  counters_ = PredictionCounters{};
  maps_pose_ = T_world_cam;
  index_at_maps_pose_ = pose.draw_index;
  if (pose.draw_index) {
    index_map_.T_world_cam = T_world_cam;
    clear_index_map();
  }
  clear_tracking_maps();
  timings_.clear_ms = lap_ms(t);
  render(pool, pose, counters_);
  timings_.render_ms = lap_ms(t);
  resolve(pool, pose);
  timings_.resolve_ms = lap_ms(t);
  for (int l = 0; l < levels_; ++l) {
    if (l > 0) {
      downsample_depth_intensity(level_[l - 1].depth, level_[l - 1].intensity, level_[l].depth, level_[l].intensity,
                                 options_.pyramid_depth_threshold_m);
      vertex_normal(l);
    }
    gradients_and_holes(l);
  }
  timings_.pyramid_ms = lap_ms(t);
  timings_.total_ms = std::chrono::duration<double, std::milli>(t - start).count();
  return Status::success();
}

void ModelPredictor::render_index_map(const SurfelPool& pool, const SE3& T_world_cam, int32_t seen_since) {
  // No surfel reaches an infinite confidence, so none is a tracking candidate: render() draws no disc
  // and leaves the tracking maps as the last predict() made them.
  Pose pose = make_pose(T_world_cam, kInf, INT32_MIN, INT32_MAX);
  pose.index_oldest = seen_since;
  index_map_.T_world_cam = T_world_cam;
  clear_index_map();
  PredictionCounters counters;
  render(pool, pose, counters);
  index_at_maps_pose_ = false;
}

void ModelPredictor::draw_index_map_at_prediction(const SurfelPool& pool) {
  if (index_at_maps_pose_) return;
  render_index_map(pool, maps_pose_);
  index_at_maps_pose_ = true;
}

void ModelPredictor::clear_index_map() {
  // id -1 is all-ones bytes and depth 0.0f all-zero bytes: plain memsets.
  std::memset(index_map_.id.data(), 0xFF, index_map_.id.size() * sizeof(int32_t));
  std::memset(index_map_.depth.data(), 0, index_map_.depth.size() * sizeof(float));
}

void ModelPredictor::clear_tracking_maps() {
  std::memset(winner_.data(), 0xFF, winner_.size() * sizeof(int32_t));
  Image<float>& key = level_[0].depth;
  std::fill(key.data(), key.data() + key.size(), kInf);
}

namespace {

// One block of surfels after the branch-free transform: camera-frame centres (metres), the linear
// index-map pixel of each centre (-1 = not in the grid or outside the clip range) and whether the
// surfel is a tracking candidate (stable, in the active window, facing the camera, within the clip
// range, centred near enough to the image for its disc to reach it).
struct Block {
  alignas(64) float xc[kBlock];
  alignas(64) float yc[kBlock];
  alignas(64) float zc[kBlock];
  alignas(64) int32_t pixel[kBlock];
  alignas(64) int32_t candidate[kBlock];
};

// Projection constants of the index grid plus the clip range and the candidate thresholds.
struct Projection {
  float fx, fy, cx, cy;  // index grid intrinsics, pixels
  float u_max, v_max;    // grid width / height - 0.5: a centre rounds into the grid when u in [-0.5, u_max)
  float last_col, last_row;  // grid width / height - 1
  // A tracking candidate's centre must lie in this box (index-grid coordinates): the working image
  // widened by the footprint cap, beyond which no pixel of its disc can be in the image.
  float cand_u_lo, cand_u_hi, cand_v_lo, cand_v_hi;
  int32_t width;         // index grid width, pixels
  float near_m, far_m;
};

// Transforms and classifies the n surfels whose pool columns start at the given pointers. Written
// without branches (only selects) over plain arrays so that the compiler vectorises it (SSE4.1 /
// NEON baseline); the float-to-int conversions see only values clamped into the grid.
void transform_block(const float* __restrict x, const float* __restrict y, const float* __restrict z,
                     const float* __restrict nx, const float* __restrict ny, const float* __restrict nz,
                     const float* __restrict conf, const int32_t* __restrict last_seen, int n, const float* r,
                     const float* t, const float* c, float min_confidence, int32_t oldest_frame, int32_t seen_before,
                     const Projection& k, Block& b) {
  const float r00 = r[0], r01 = r[1], r02 = r[2], r10 = r[3], r11 = r[4], r12 = r[5], r20 = r[6], r21 = r[7], r22 = r[8];
  const float t0 = t[0], t1 = t[1], t2 = t[2], c0 = c[0], c1 = c[1], c2 = c[2];
  float* __restrict xc = b.xc;
  float* __restrict yc = b.yc;
  float* __restrict zc = b.zc;
  int32_t* __restrict pixel = b.pixel;
  int32_t* __restrict candidate = b.candidate;
  for (int i = 0; i < n; ++i) {
    const float px = x[i], py = y[i], pz = z[i];
    const float cx_ = r00 * px + r01 * py + r02 * pz + t0;
    const float cy_ = r10 * px + r11 * py + r12 * pz + t1;
    const float cz_ = r20 * px + r21 * py + r22 * pz + t2;
    xc[i] = cx_;
    yc[i] = cy_;
    zc[i] = cz_;
    // Every comparison is evaluated and combined with `&` (no short circuit) and all arithmetic is
    // unconditional, leaving only selects: GCC (under its default -ftrapping-math) does not
    // if-convert a loop that would evaluate a float comparison or operation speculatively.
    const bool in_range = (cz_ >= k.near_m) & (cz_ <= k.far_m);
    const float inv_z = 1.0f / std::max(k.near_m, cz_);  // finite; only used where in_range
    const float u = k.fx * cx_ * inv_z + k.cx;
    const float v = k.fy * cy_ * inv_z + k.cy;
    const bool in_grid = in_range & (u >= -0.5f) & (u < k.u_max) & (v >= -0.5f) & (v < k.v_max);
    // u + 0.5 >= 0 inside the grid, where truncation is the floor: the nearest index pixel. The value
    // converted is clamped into the grid first (an out-of-range float-to-int conversion is undefined;
    // this operand order also maps NaN to a bound), by min/max rather than a select, which GCC would
    // turn into a conditional conversion and refuse to vectorise.
    const float ur = u + 0.5f, vr = v + 0.5f;
    const auto iu = static_cast<int32_t>(std::min(k.last_col, std::max(0.0f, ur)));
    const auto iv = static_cast<int32_t>(std::min(k.last_row, std::max(0.0f, vr)));
    pixel[i] = in_grid ? iv * k.width + iu : -1;
    // Facing the camera: n . (c - p) > 0, in the world frame (the normal is not rotated here).
    const float facing = nx[i] * (c0 - px) + ny[i] * (c1 - py) + nz[i] * (c2 - pz);
    const bool near_image = (u >= k.cand_u_lo) & (u <= k.cand_u_hi) & (v >= k.cand_v_lo) & (v <= k.cand_v_hi);
    candidate[i] = static_cast<int32_t>(in_range & near_image & (facing > 0.0f) & (conf[i] >= min_confidence) &
                                        (last_seen[i] >= oldest_frame) & (last_seen[i] < seen_before));
  }
}

// The discs of one block's tracking candidates, set up for kernels::splat_disc: camera-frame
// normals, the plane offset, squared radius, the key's tie weight and the pixel box; `draw` is 0 for
// a surfel that is no candidate, has no radius or whose box misses the image.
struct DiscBlock {
  alignas(64) float nx[kBlock];
  alignas(64) float ny[kBlock];
  alignas(64) float nz[kBlock];
  alignas(64) float np[kBlock];
  alignas(64) float r2[kBlock];
  alignas(64) float tie[kBlock];
  alignas(64) int32_t x0[kBlock];
  alignas(64) int32_t x1[kBlock];
  alignas(64) int32_t y0[kBlock];
  alignas(64) int32_t y1[kBlock];
  alignas(64) int32_t draw[kBlock];
};

// Constants of setup_discs(): the working intrinsics and the options that shape a disc.
struct DiscSetup {
  float fx, fy, cx, cy;  // working image, pixels
  float wmax, hmax;      // width - 1, height - 1
  float cap_px;          // PredictionOptions::max_splat_radius_px
  float tie_fraction;    // PredictionOptions::splat_tie_depth_fraction
};

// Sets up the discs of the n surfels of block `b` (world normals and radii from the pool columns).
// The screen half-extents are rigorous and tight for tilted discs (fusion makes grazing surfels up
// to 4x larger, so a bound that ignores the orientation tests several times the pixels the thin
// ellipse covers): a disc point p + e (e in the plane, |e| <= r) projects to u - u_c = fx (e_x - tx
// e_z) / (zc + e_z). The numerator's maximum over the disc is r sqrt(|w|^2 - (n . w)^2) for w = (1,
// 0, -tx) (a linear function on a disc); the denominator is at least zc - r sqrt(1 - nz^2). Likewise
// for v. Capped at cap_px (also where the denominator bound is not positive).
// Branch-free over plain arrays (only selects) so that the compiler vectorises it, as
// transform_block; per lane the operations are those a scalar loop would do, in the same order.
void setup_discs(const Block& b, const float* __restrict wnx, const float* __restrict wny,
                 const float* __restrict wnz, const float* __restrict radius, int n, const float* r,
                 const DiscSetup& k, DiscBlock& d) {
  const float r00 = r[0], r01 = r[1], r02 = r[2], r10 = r[3], r11 = r[4], r12 = r[5], r20 = r[6], r21 = r[7], r22 = r[8];
  for (int i = 0; i < n; ++i) {
    const float rad = radius[i];
    const float wx = wnx[i], wy = wny[i], wz = wnz[i];
    const float nx = r00 * wx + r01 * wy + r02 * wz;
    const float ny = r10 * wx + r11 * wy + r12 * wz;
    const float nz = r20 * wx + r21 * wy + r22 * wz;
    const float xc = b.xc[i], yc = b.yc[i], zc = b.zc[i];
    const float inv_z = 1.0f / zc;  // zc >= near > 0 for every candidate
    const float u = k.fx * xc * inv_z + k.cx, v = k.fy * yc * inv_z + k.cy;
    const float tx = xc * inv_z, ty = yc * inv_z;
    const float z_min = zc - rad * std::sqrt(std::max(0.0f, 1.0f - nz * nz));
    const float nwx = nx - nz * tx, nwy = ny - nz * ty;
    const float sx = std::sqrt(std::max(0.0f, 1.0f + tx * tx - nwx * nwx));
    const float sy = std::sqrt(std::max(0.0f, 1.0f + ty * ty - nwy * nwy));
    // Every operation unconditional, then selects: GCC does not vectorise a loop with a float
    // operation inside a condition unless it may speculate it (-fno-trapping-math).
    const bool bounded = z_min > 0.0f;
    const float z_den = bounded ? z_min : 1.0f;
    const float hx_bound = std::min(k.fx * rad * sx / z_den, k.cap_px);
    const float hy_bound = std::min(k.fy * rad * sy / z_den, k.cap_px);
    const float hx = bounded ? hx_bound : k.cap_px;
    const float hy = bounded ? hy_bound : k.cap_px;
    // The box is ceil(u - hx) .. floor(u + hx) (likewise in v) clipped to the image; it reaches the
    // image when u + hx >= 0 and u - hx <= wmax (wmax an integer), false for NaN. Without ceil and
    // floor, which GCC does not vectorise under -ftrapping-math: the ends are first clamped into
    // [0, wmax] (max(0, x) first also maps NaN to 0), where truncation is the floor and the ceiling
    // is the truncation plus one unless the value is an integer.
    const float lo_u = std::min(k.wmax, std::max(0.0f, u - hx)), hi_u = std::min(k.wmax, std::max(0.0f, u + hx));
    const float lo_v = std::min(k.hmax, std::max(0.0f, v - hy)), hi_v = std::min(k.hmax, std::max(0.0f, v + hy));
    const bool on_screen = (u + hx >= 0.0f) & (u - hx <= k.wmax) & (v + hy >= 0.0f) & (v - hy <= k.hmax);
    const auto x0 = static_cast<int32_t>(lo_u), y0 = static_cast<int32_t>(lo_v);
    d.x0[i] = x0 + static_cast<int32_t>(static_cast<float>(x0) < lo_u);
    d.x1[i] = static_cast<int32_t>(hi_u);
    d.y0[i] = y0 + static_cast<int32_t>(static_cast<float>(y0) < lo_v);
    d.y1[i] = static_cast<int32_t>(hi_v);
    d.nx[i] = nx;
    d.ny[i] = ny;
    d.nz[i] = nz;
    d.np[i] = nx * xc + ny * yc + nz * zc;  // < 0: the surfel faces the camera
    const float r2 = rad * rad;
    d.r2[i] = r2;
    d.tie[i] = k.tie_fraction / r2;  // per m^2 of e^2
    d.draw[i] = static_cast<int32_t>((b.candidate[i] != 0) & (rad > 0.0f) & on_screen);
  }
}

// The view a render draws, as six half-spaces a . p + d >= 0 over world points p (unit a, metres):
// near and far clip planes and the four sides of the candidate box (Projection), which holds the
// index grid as well. A surfel whose centre fails any of them is neither in the index map nor a
// tracking candidate (transform_block). In double, and with a margin (kCullMarginM) so that float
// rounding in transform_block never draws a surfel of a block judged unseen.
struct BlockCull {
  static constexpr double kCullMarginM = 1e-3;
  double a[6][3];
  double d[6];
  // Whether some point of the block's box passes every half-space (the box's corner furthest along
  // each normal). A box with a NaN bound passes (visited, never wrongly skipped); no block below
  // SurfelPool::blocks() is empty.
  bool may_see(const SurfelPool::BlockBounds& b) const {
    for (int p = 0; p < 6; ++p) {
      double s = d[p] + kCullMarginM;
      for (int k = 0; k < 3; ++k) s += a[p][k] * (a[p][k] >= 0 ? b.hi[k] : b.lo[k]);
      if (s < 0) return false;
    }
    return true;
  }
};

// The half-spaces of a render at camera = r world + t (r row-major) with projection k: in the camera
// frame z >= near, z <= far, fx x + (cx - u_lo) z >= 0, (u_hi - cx) z - fx x >= 0 and likewise in
// y, then a_world = r^T a_cam and d = a_cam . t + d_cam, normalised.
BlockCull make_cull(const float* r, const float* t, const Projection& k) {
  const double cam[6][4] = {
      {0, 0, 1, -static_cast<double>(k.near_m)},
      {0, 0, -1, static_cast<double>(k.far_m)},
      {k.fx, 0, static_cast<double>(k.cx) - k.cand_u_lo, 0},
      {-static_cast<double>(k.fx), 0, static_cast<double>(k.cand_u_hi) - k.cx, 0},
      {0, k.fy, static_cast<double>(k.cy) - k.cand_v_lo, 0},
      {0, -static_cast<double>(k.fy), static_cast<double>(k.cand_v_hi) - k.cy, 0},
  };
  BlockCull c;
  for (int p = 0; p < 6; ++p) {
    double a[3], norm2 = 0;
    for (int j = 0; j < 3; ++j) {
      a[j] = 0;
      for (int i = 0; i < 3; ++i) a[j] += static_cast<double>(r[3 * i + j]) * cam[p][i];
      norm2 += a[j] * a[j];
    }
    double d = cam[p][3];
    for (int i = 0; i < 3; ++i) d += cam[p][i] * static_cast<double>(t[i]);
    const double inv = 1.0 / std::sqrt(norm2);
    for (int j = 0; j < 3; ++j) c.a[p][j] = a[j] * inv;
    c.d[p] = d * inv;
  }
  return c;
}

}  // namespace

void ModelPredictor::render(const SurfelPool& pool, const Pose& pose, PredictionCounters& counters) {
  const Intrinsics& ki = index_map_.intrinsics;
  const float s = static_cast<float>(index_map_.scale);
  const float cap = options_.max_splat_radius_px;
  Projection k;
  k.fx = ki.fx;
  k.fy = ki.fy;
  k.cx = ki.cx;
  k.cy = ki.cy;
  k.u_max = static_cast<float>(ki.width) - 0.5f;
  k.v_max = static_cast<float>(ki.height) - 0.5f;
  k.last_col = static_cast<float>(ki.width - 1);
  k.last_row = static_cast<float>(ki.height - 1);
  k.width = ki.width;
  k.near_m = options_.near_clip_m;
  k.far_m = options_.far_clip_m;
  // Working pixel u_w = (u + 0.5) / s - 0.5 (Intrinsics::scaled_to); a disc reaches the image only if
  // -cap - 0.5 <= u_w <= W - 0.5 + cap, i.e. -cap s - 0.5 <= u <= (W + cap) s - 0.5.
  const float w = static_cast<float>(level_[0].intrinsics.width), h = static_cast<float>(level_[0].intrinsics.height);
  k.cand_u_lo = -cap * s - 0.5f;
  k.cand_u_hi = (w + cap) * s - 0.5f;
  k.cand_v_lo = -cap * s - 0.5f;
  k.cand_v_hi = (h + cap) * s - 0.5f;
  int32_t* ids = index_map_.id.data();
  float* depths = index_map_.depth.data();
  IndexSurface* surfaces = index_map_.surface.data();
  const BlockCull cull = make_cull(pose.r, pose.t, k);
  const bool use_bounds = pool.bounds_current();
  const int64_t block_count = pool.blocks();
  const SurfelPool::BlockBounds* bounds = pool.block_bounds();
  const bool want_candidates = pose.min_confidence < kInf;
  // The next block at or after `b` that may hold a surfel this render draws (block_count if none):
  // its box meets the view and its times meet a window drawn (slam/surfel_pool.h: block bounds).
  // Skipping the others changes nothing drawn: each of their surfels would be masked out anyway.
  const auto next_block = [&](int64_t b) {
    if (!use_bounds) return b;
    for (; b < block_count; ++b) {
      const SurfelPool::BlockBounds& bb = bounds[b];
      const bool index_wanted = pose.draw_index && bb.seen_max >= pose.index_oldest;
      const bool candidates_wanted =
          want_candidates && bb.seen_max >= pose.oldest_frame && bb.seen_min < pose.seen_before;
      if ((index_wanted || candidates_wanted) && cull.may_see(bb)) break;
    }
    return b;
  };
  // Software pipeline over blocks: block j+1 is transformed and its index-map entries prefetched
  // before block j is scattered and rasterised. The index map (4.9 MB of depths and as much of ids
  // at 320x240, scale 4) does not fit in cache and the centres land all over it; this way the
  // misses of a block overlap each other and the rasterisation of the previous block instead of
  // stalling the depth test one by one.
  Block blocks[2];
  DiscBlock discs;
  DiscSetup disc_setup;
  {
    const Intrinsics& K = level_[0].intrinsics;
    disc_setup.fx = K.fx;
    disc_setup.fy = K.fy;
    disc_setup.cx = K.cx;
    disc_setup.cy = K.cy;
    disc_setup.wmax = static_cast<float>(K.width - 1);
    disc_setup.hmax = static_cast<float>(K.height - 1);
    disc_setup.cap_px = cap;
    disc_setup.tie_fraction = options_.splat_tie_depth_fraction;
  }
  const int64_t size = pool.size();
  const auto prepare = [&](int64_t begin, Block& b) {
    const int n = static_cast<int>(std::min<int64_t>(kBlock, size - begin));
    transform_block(pool.x() + begin, pool.y() + begin, pool.z() + begin, pool.nx() + begin, pool.ny() + begin,
                    pool.nz() + begin, pool.confidence() + begin, pool.last_seen() + begin, n, pose.r, pose.t, pose.c,
                    pose.min_confidence, pose.oldest_frame, pose.seen_before, k, b);
    for (int i = 0; i < (pose.draw_index ? n : 0); ++i) {
      const int32_t p = b.pixel[i];
      if (p < 0) continue;
      __builtin_prefetch(depths + p, 1);
      __builtin_prefetch(ids + p, 1);
      __builtin_prefetch(surfaces + p, 1);
    }
  };
  int64_t drawn = 0, candidates = 0, splatted = 0, visited = 0;
  float* key = level_[0].depth.data();
  const int image_width = level_[0].intrinsics.width;
  int64_t block = next_block(0), following = block_count;
  if (block < block_count) prepare(block * kBlock, blocks[0]);
  for (int64_t j = 0; block < block_count; ++j, block = following) {
    const int64_t begin = block * kBlock;
    const int n = static_cast<int>(std::min<int64_t>(kBlock, size - begin));
    following = next_block(block + 1);
    if (following < block_count) prepare(following * kBlock, blocks[(j + 1) & 1]);
    ++visited;
    const Block& b = blocks[j & 1];
    // (a) Index map: the nearest centre wins each index pixel (depth 0 = empty), with the copy of
    // its normal and confidence that fusion gates on (slam/index_map.h).
    const float *nx = pool.nx() + begin, *ny = pool.ny() + begin, *nz = pool.nz() + begin;
    const float* conf = pool.confidence() + begin;
    const int32_t* seen = pool.last_seen() + begin;
    for (int i = 0; i < (pose.draw_index ? n : 0); ++i) {
      const int32_t p = b.pixel[i];
      if (p < 0 || seen[i] < pose.index_oldest) continue;
      ++drawn;
      const float d = depths[p];
      if (d == 0.0f || b.zc[i] < d) {
        depths[p] = b.zc[i];
        ids[p] = static_cast<int32_t>(begin + i);
        surfaces[p] = IndexSurface{nx[i], ny[i], nz[i], conf[i]};
      }
    }
    // (b) Tracking maps: discs of the candidates, set up for the whole block, then rasterised.
    int32_t block_candidates = 0;
    for (int i = 0; i < n; ++i) block_candidates += b.candidate[i];
    candidates += block_candidates;
    // The pool is in spatial order (slam/spatial_order.h), so many blocks lie wholly outside the view.
    if (block_candidates == 0) continue;
    setup_discs(b, pool.nx() + begin, pool.ny() + begin, pool.nz() + begin, pool.radius() + begin, n, pose.r,
                disc_setup, discs);
    for (int i = 0; i < n; ++i) {
      if (!discs.draw[i]) continue;
      ++splatted;
      kernels::SplatDisc d;
      d.nx = discs.nx[i];
      d.ny = discs.ny[i];
      d.nz = discs.nz[i];
      d.xc = b.xc[i];
      d.yc = b.yc[i];
      d.zc = b.zc[i];
      d.np = discs.np[i];
      d.r2 = discs.r2[i];
      d.tie = discs.tie[i];
      d.near = options_.near_clip_m;
      d.id = static_cast<int32_t>(begin + i);
      d.x0 = discs.x0[i];
      d.x1 = discs.x1[i];
      d.y0 = discs.y0[i];
      d.y1 = discs.y1[i];
      // A pixel of the box is covered when its ray d = (ray_x, ray_y, 1) meets the surfel's plane
      // n . (X - p) = 0 at a point X = z d within the radius of p (z = (n . p) / (n . d), the camera
      // depth of that point); its visibility key is z (1 + tie e^2 / r^2), e = |X - p|
      // (PredictionOptions::splat_tie_depth_fraction), and the smallest key wins. Computed as selects
      // (kernels/splat_disc.h; SIMD across the pixels of a row, bit-identical to its scalar twin).
      kernels::splat_disc(d, ray_x_.data(), ray_y_.data(), key, winner_.data(), image_width);
    }
  }
  if (pose.draw_index) index_map_.surfels_drawn = drawn;
  counters.blocks_visited = visited;
  counters.blocks = block_count;
  counters.index_surfels = drawn;
  counters.tracking_candidates = candidates;
  counters.splatted_surfels = splatted;
}

// Level 0 from the winners: vertex = z (ray_x, ray_y, 1) with z = (n . p) / (n . d) the depth of the
// ray's intersection with the winner's plane (recomputed: the buffer held the visibility key), normal =
// the winner's normal in the camera frame, colour and grey from the winner; depth 0 where none.
void ModelPredictor::resolve(const SurfelPool& pool, const Pose& pose) {
  PredictedLevel& lv = level_[0];
  const int w = lv.intrinsics.width, h = lv.intrinsics.height;
  const Eigen::Vector3f zero = Eigen::Vector3f::Zero();
  const float* r = pose.r;
  const float* t = pose.t;
  const float *px = pool.x(), *py = pool.y(), *pz = pool.z();
  const float *pnx = pool.nx(), *pny = pool.ny(), *pnz = pool.nz();
  const uint32_t* colors = pool.color();
  int64_t valid = 0;
  for (int y = 0; y < h; ++y) {
    const std::size_t row = static_cast<std::size_t>(y) * w;
    const int32_t* ids = winner_.data() + row;
    float* z = lv.depth.data() + row;
    Eigen::Vector3f* vert = lv.vertex.data() + row;
    Eigen::Vector3f* norm = lv.normal.data() + row;
    float* inten = lv.intensity.data() + row;
    Rgb8* col = color_.data() + row;
    const float dy = ray_y_(y, 0);
    // The winners' pool columns are random accesses: prefetch those of the next row while this one
    // is resolved (once per 16-surfel cache line run of ids: neighbouring pixels mostly share one).
    if (y + 1 < h) {
      const int32_t* next = ids + w;
      int32_t last_line = -1;
      for (int x = 0; x < w; ++x) {
        const int32_t id = next[x];
        if (id < 0 || (id >> 4) == last_line) continue;
        last_line = id >> 4;
        __builtin_prefetch(px + id);
        __builtin_prefetch(py + id);
        __builtin_prefetch(pz + id);
        __builtin_prefetch(pnx + id);
        __builtin_prefetch(pny + id);
        __builtin_prefetch(pnz + id);
        __builtin_prefetch(colors + id);
      }
    }
    for (int x = 0; x < w; ++x) {
      const int32_t id = ids[x];
      if (id < 0) {
        z[x] = 0.0f;
        vert[x] = zero;
        norm[x] = zero;
        inten[x] = 0.0f;
        col[x] = Rgb8{0, 0, 0};
        continue;
      }
      ++valid;
      const float wx = pnx[id], wy = pny[id], wz = pnz[id];
      const Eigen::Vector3f n(r[0] * wx + r[1] * wy + r[2] * wz, r[3] * wx + r[4] * wy + r[5] * wz,
                              r[6] * wx + r[7] * wy + r[8] * wz);
      const float cx_ = r[0] * px[id] + r[1] * py[id] + r[2] * pz[id] + t[0];
      const float cy_ = r[3] * px[id] + r[4] * py[id] + r[5] * pz[id] + t[1];
      const float cz_ = r[6] * px[id] + r[7] * py[id] + r[8] * pz[id] + t[2];
      const float rx = ray_x_(x, 0);
      // The expressions of splat(): z is the depth that passed its tests (up to rounding).
      const float d = (n.x() * cx_ + n.y() * cy_ + n.z() * cz_) / (n.x() * rx + (n.y() * dy + n.z()));
      z[x] = d;
      vert[x] = Eigen::Vector3f(rx * d, dy * d, d);
      norm[x] = n;  // unit: pool normals are unit (fusion renormalises them) and R is a rotation
      const uint32_t c = colors[id];
      col[x] = Rgb8{unpack_r(c), unpack_g(c), unpack_b(c)};
      inten[x] = grey(c);
    }
  }
  counters_.valid_pixels = valid;
}

namespace {

// Sobel / 8 at a border pixel (x, y) (the rule of kernels/gradient_fill_row.h, whose kernel does the
// interior): taps without depth, or outside the image, take the centre's value; 0 at a pixel without
// depth.
void gradient_at(const Image<float>& depth, const Image<float>& intensity, int x, int y, float* gx, float* gy) {
  const int w = depth.width(), h = depth.height();
  const std::size_t c = static_cast<std::size_t>(y) * w + x;
  const float centre = intensity.data()[c];
  const auto tap = [&](int dx, int dy) {
    if (x + dx < 0 || y + dy < 0 || x + dx >= w || y + dy >= h) return centre;
    const std::size_t k = c + static_cast<std::ptrdiff_t>(dy) * w + dx;
    return depth.data()[k] > 0.0f ? intensity.data()[k] : centre;
  };
  const float ul = tap(-1, -1), u = tap(0, -1), ur = tap(1, -1);
  const float l = tap(-1, 0), r = tap(1, 0);
  const float dl = tap(-1, 1), d = tap(0, 1), dr = tap(1, 1);
  const bool valid = depth.data()[c] > 0.0f;
  *gx = valid ? ((ur + 2.0f * r + dr) - (ul + 2.0f * l + dl)) * 0.125f : 0.0f;
  *gy = valid ? ((dl + 2.0f * d + dr) - (ul + 2.0f * u + ur)) * 0.125f : 0.0f;
}

}  // namespace

// Vertex and normal of level l from its depth. Vertex: the depth back-projected on the pixel's ray.
// Normal: (V(x, y+1) - V(x, y-1)) x (V(x+1, y) - V(x-1, y)), normalised and turned toward the camera;
// none on the border, next to a pixel without depth, or across a depth step steeper than a surface
// at normal_min_grazing_deg to the ray. Because the coarse depth was smoothed over 4x4 finer pixels
// and the differences span 2 coarse pixels, these normals are far less noisy than a mean of the finer
// normals. Measured with a model made from one noisy synthetic frame (320x240, 3 levels): with the
// mean of the finer normals the tracker diverged (8-12 cm error) on office frames 10 -> 14 and living
// room 10 -> 16; with these it converges (1.2 mm, 3.5 mm) exactly where frame-to-frame tracking of
// the same pairs does (0.5 mm, 3.2 mm), and fails where that fails too (gaps of 16-21 cm).
void ModelPredictor::vertex_normal(int l) {
  PredictedLevel& lv = level_[l];
  const Intrinsics& K = lv.intrinsics;
  const float cot = 1.0f / std::tan(options_.normal_min_grazing_deg * static_cast<float>(M_PI / 180.0));
  // Largest depth step per metre of depth; the normals divided by their length (this file's rule
  // before slam/vertex_normal.h, kept so that no prediction changed).
  vertex_normal_maps(lv.depth, K, cot / K.fx, cot / K.fy, /*divide=*/true, lv.vertex, lv.normal);
}

// Sobel / 8 of the intensity (grey levels per pixel of level l), and the holes of the intensity
// filled (kernels/gradient_fill_row.h states both rules). Gradients: a neighbour without a prediction
// (or beyond the border) takes the centre's value, so a hole's border is not an edge; pixels without
// a prediction get gradient 0. Holes: pixels without a prediction take the mean intensity of their
// predicted 3x3 neighbours (0 when none): the tracker samples the reference bilinearly and gates only
// on the nearest pixel, so a sample next to a hole would otherwise blend in black. Both read only
// predicted pixels, and the filling writes only the others, so one pass does both and rows can be
// finished one by one: the border pixels here, each interior row by the kernel (its filled row into
// a scratch row, copied back).
void ModelPredictor::gradients_and_holes(int l) {
  PredictedLevel& lv = level_[l];
  const int w = lv.intrinsics.width, h = lv.intrinsics.height;
  const auto gradient_border = [&](int x, int y) {
    gradient_at(lv.depth, lv.intensity, x, y, &lv.grad_x(x, y), &lv.grad_y(x, y));
  };
  const auto fill_border = [&](int x, int y) {
    if (lv.depth(x, y) > 0.0f) return;
    float sum = 0.0f;
    int n = 0;
    for (int yy = std::max(y - 1, 0); yy <= std::min(y + 1, h - 1); ++yy)
      for (int xx = std::max(x - 1, 0); xx <= std::min(x + 1, w - 1); ++xx) {
        if (!(lv.depth(xx, yy) > 0.0f)) continue;
        sum += lv.intensity(xx, yy);
        ++n;
      }
    lv.intensity(x, y) = n > 0 ? sum / static_cast<float>(n) : 0.0f;
  };
  const auto border = [&](int x, int y) {
    gradient_border(x, y);
    fill_border(x, y);
  };
  const bool interior = w >= 3 && h >= 3;
  for (int y = 0; y < h; ++y) {
    if (y == 0 || y == h - 1 || !interior) {
      for (int x = 0; x < w; ++x) border(x, y);
      continue;
    }
    border(0, y);
    border(w - 1, y);
    const std::size_t row = static_cast<std::size_t>(y) * w;
    kernels::GradientFillRow r;
    for (int k = 0; k < 3; ++k) {
      r.intensity[k] = lv.intensity.data() + row + static_cast<std::size_t>(k) * w - w;
      r.depth[k] = lv.depth.data() + row + static_cast<std::size_t>(k) * w - w;
    }
    float* filled = row_scratch_.data();
    kernels::gradient_fill_row(r, 1, w - 1, lv.grad_x.data() + row, lv.grad_y.data() + row, filled);
    std::memcpy(lv.intensity.data() + row + 1, filled + 1, static_cast<std::size_t>(w - 2) * sizeof(float));
  }
}

}  // namespace ef::slam
