// Surfel fusion (see surfel_fusion.h for the steps, rules and references).
#include "slam/surfel_fusion.h"

#include "core/stopwatch.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <sstream>

#include "kernels/fusion_gates.h"
#include "slam/preprocess.h"

namespace ef::slam {

namespace {

using Clock = SteadyClock;

constexpr float kDegToRad = 3.14159265358979f / 180.0f;
constexpr int kMaxScale = 4;  // IndexMap: 1..4
constexpr int kMaxMargin = 4;  // FusionOptions::search_margin_index_px
constexpr int kMaxWindow = kMaxScale + 2 * kMaxMargin;
constexpr uint8_t kGreyLevel = 128;  // colour of new surfels when the frame has none
constexpr int kPrefetchAhead = 32;   // index pixels (128 bytes) ahead of a window row
// Working pixels ahead whose candidates' per-surfel data is prefetched (see scan_window).
constexpr int kSurfelPrefetchPixels = 3;

bool finite_positive(float v) { return std::isfinite(v) && v > 0.0f; }

}  // namespace

// ---------------------------------------------------------------------------------------------
// Options

const opt::Table<FusionOptions>& FusionOptions::table() {
  static const opt::Table<FusionOptions> t = {
      {"fusion_stride", "", "", &FusionOptions::pixel_stride, "pixels", opt::between(1, 2),
       "fuse every pixel (1, ElasticFusion) or every other pixel of every other row (2: each surfel stands for its "
       "2x2 cell, at the cell's mean depth and colour; a map a third the size, fusion and prediction at about half "
       "the cost)"},
  };
  return t;
}

Status FusionOptions::validate() const {
  EF_RETURN_IF_ERROR(opt::check_table(*this, table(), "fusion"));
  const auto bad = [](const char* field) {
    return error(ErrorCode::kInvalidArgument, std::string("FusionOptions.") + field + " out of range");
  };
  if (!finite_positive(stable_confidence)) return bad("stable_confidence");
  if (!finite_positive(confidence_sigma)) return bad("confidence_sigma");
  if (!finite_positive(association_depth_base_m)) return bad("association_depth_base_m");
  if (!(association_depth_quadratic >= 0.0f) || !std::isfinite(association_depth_quadratic))
    return bad("association_depth_quadratic");
  if (search_margin_index_px < 0 || search_margin_index_px > kMaxMargin) return bad("search_margin_index_px");
  if (!(association_normal_deg > 0.0f && association_normal_deg <= 90.0f)) return bad("association_normal_deg");
  if (!(max_radius_incidence_factor >= 1.0f) || !std::isfinite(max_radius_incidence_factor))
    return bad("max_radius_incidence_factor");
  if (!(max_radius_growth >= 1.0f) || !std::isfinite(max_radius_growth)) return bad("max_radius_growth");
  if (unstable_lifetime_frames < 1) return bad("unstable_lifetime_frames");
  if (lifetime_sweep_per_frame < 0) return bad("lifetime_sweep_per_frame");
  if (!(free_space_gate_factor >= 1.0f) || !std::isfinite(free_space_gate_factor)) return bad("free_space_gate_factor");
  if (!(free_space_penalty >= 0.0f) || !std::isfinite(free_space_penalty)) return bad("free_space_penalty");
  if (normal_level < 0 || normal_level > 1) return bad("normal_level");
  if (!(merge_max_distance_px >= 0.0f && merge_max_distance_px <= 4.0f)) return bad("merge_max_distance_px");
  if (!(merge_normal_deg > 0.0f && merge_normal_deg <= 90.0f)) return bad("merge_normal_deg");
  if (!(merge_max_radius_ratio >= 1.0f) || !std::isfinite(merge_max_radius_ratio)) return bad("merge_max_radius_ratio");
  return Status::success();
}

std::string FusionOptions::describe() const {
  std::ostringstream s;
  s << "stable_confidence " << stable_confidence << "  # confidence of a stable surfel\n"
    << "confidence_sigma " << confidence_sigma << "  # Gaussian of the normalised radial pixel distance\n"
    << "association_depth_base_m " << association_depth_base_m << " m\n"
    << "association_depth_quadratic " << association_depth_quadratic << " m per m^2  # gate = base + quadratic z^2\n"
    << "search_margin_index_px " << search_margin_index_px << " index px\n"
    << "association_normal_deg " << association_normal_deg << " deg\n"
    << "max_radius_incidence_factor " << max_radius_incidence_factor << "  # cap on 1/|cos incidence|\n"
    << "max_radius_growth " << max_radius_growth << "  # larger measurements only add confidence\n"
    << "unstable_lifetime_frames " << unstable_lifetime_frames << " frames\n"
    << "lifetime_sweep_per_frame " << lifetime_sweep_per_frame << " surfels\n"
    << "free_space_gate_factor " << free_space_gate_factor << " depth gates\n"
    << "free_space_penalty " << free_space_penalty << "  # confidence taken from a violating stable surfel\n"
    << "merge_max_distance_px " << merge_max_distance_px << " px\n"
    << "merge_normal_deg " << merge_normal_deg << " deg\n"
    << "merge_max_radius_ratio " << merge_max_radius_ratio << "\n"
    << "fuse_raw_depth " << (fuse_raw_depth ? "true" : "false") << "  # positions from raw (true) or filtered depth\n"
    << "normal_level " << normal_level << "  # pyramid level of the fused normals\n"
    << "row_gates " << (row_gates ? "true" : "false") << "  # candidates' static gates a row at a time\n"
    << "pixel_stride " << pixel_stride << " px  # every pixel (1) or every other of every other row (2)\n";
  return s.str();
}

// ---------------------------------------------------------------------------------------------
// Per-frame context

struct SurfelFusion::FrameContext {
  Eigen::Matrix3f R_wc;  // current camera -> world
  Eigen::Vector3f t_wc;
  Eigen::Matrix3f R_ic;  // current camera -> index-map camera
  Eigen::Vector3f t_ic;
  Intrinsics Ki;         // of the index grid
  bool has_index = false;
  ImageView<const float> depth;              // fused depth (raw or filtered), metres, 0 = invalid
  ImageView<const Eigen::Vector3f> normal;   // filtered normals of level 0, current camera
  ImageView<const Eigen::Vector3f> coarse_normal;  // of level normal_level (empty: level 0 only)
  ImageView<const float> coarse_depth;             // metres, of the same level
  int64_t pool_size = 0;                     // ids >= this are not in the index map's pool
};

struct SurfelFusion::PixelContext {
  int x = 0, y = 0;
  Eigen::Vector3f v;    // vertex, current camera, metres
  Eigen::Vector3f n_c;  // unit normal, current camera (toward the camera)
  Eigen::Vector3f n_w;  // the same in the world frame
  Eigen::Vector3f p_i;  // the vertex in the index map's camera, metres
  float xi = 0, yi = 0; // its projection into the index grid, index pixels
  float gate = 0;       // depth gate at p_i.z(), metres
};

namespace {

// Entries of the list of seen surfels: each surfel occupies one index pixel, so at most
// min(capacity, index pixels) are seen; the same list then holds the ids to remove, plus at most
// one sweep's worth.
int64_t seen_list_capacity(int64_t pixels, int index_map_scale, int64_t pool_capacity) {
  return std::min(pool_capacity, pixels * index_map_scale * index_map_scale);
}

int64_t sweep_words(int64_t sweep) { return (sweep + 63) / 64; }

}  // namespace

std::size_t SurfelFusion::bytes_for(int width, int height, int index_map_scale, int64_t pool_capacity,
                                    const FusionOptions& options) {
  const int64_t pixels = static_cast<int64_t>(width) * height;
  const int64_t cells = pixels * index_map_scale * index_map_scale;
  const int64_t seen_entries =
      seen_list_capacity(pixels, index_map_scale, pool_capacity) + options.lifetime_sweep_per_frame;
  // cell_state_ (a byte per index pixel), seen_ (int32 per entry), unmatched_ (int32) and weight_
  // (float) per pixel, sweep_decided_ (a bit per sweep id, in 64-bit words), row_ (kRowFields floats
  // per pixel of a row) and gate_code_ (uint32 per pixel of a row).
  return static_cast<std::size_t>(cells + (seen_entries + 2 * pixels + int64_t{kRowFields + 1} * width) * 4 +
                                  sweep_words(options.lifetime_sweep_per_frame) * 8);
}

Result<SurfelFusion> SurfelFusion::create(const Intrinsics& working, int index_map_scale, int64_t pool_capacity,
                                          const FusionOptions& options) {
  EF_RETURN_IF_ERROR(options.validate());
  if (!working.valid()) return error(ErrorCode::kInvalidArgument, "surfel fusion: invalid working intrinsics");
  if (index_map_scale < 1 || index_map_scale > kMaxScale)
    return error(ErrorCode::kInvalidArgument,
                 "surfel fusion: index map scale " + std::to_string(index_map_scale) + " is outside 1..4");
  if (pool_capacity < 1 || pool_capacity > INT32_MAX)
    return error(ErrorCode::kInvalidArgument,
                 "surfel fusion: pool capacity " + std::to_string(pool_capacity) + " is outside 1..2^31-1");
  SurfelFusion f;
  f.options_ = options;
  f.K_ = working;
  f.scale_ = index_map_scale;
  f.capacity_ = pool_capacity;
  f.cos_normal_gate_ = std::cos(options.association_normal_deg * kDegToRad);
  f.cos_merge_gate_ = std::cos(options.merge_normal_deg * kDegToRad);
  f.focal_ = 0.5f * (working.fx + working.fy);
  f.radius_scale_ = options.pixel_stride == 2 ? fusion_math::kStrideTwoRadiusScale : 1.0f;

  const int64_t pixels = static_cast<int64_t>(working.width) * working.height;
  f.seen_capacity_ = seen_list_capacity(pixels, index_map_scale, pool_capacity);
  const int64_t seen_entries = f.seen_capacity_ + options.lifetime_sweep_per_frame;
  f.cells_ = pixels * index_map_scale * index_map_scale;
  f.cell_state_.reset(new uint8_t[static_cast<std::size_t>(f.cells_)]());
  f.sweep_decided_.reset(new uint64_t[static_cast<std::size_t>(sweep_words(options.lifetime_sweep_per_frame))]());
  f.seen_.reset(new int32_t[static_cast<std::size_t>(seen_entries)]);
  f.row_.reset(new float[static_cast<std::size_t>(kRowFields) * static_cast<std::size_t>(working.width)]());
  f.gate_code_.reset(new uint32_t[static_cast<std::size_t>(working.width)]());
  f.unmatched_.reset(new int32_t[static_cast<std::size_t>(pixels)]);
  f.weight_.allocate(working.width, working.height);
  f.bytes_ = bytes_for(working.width, working.height, index_map_scale, pool_capacity, options);

  // gamma: pixel distance from the principal point over that of the farthest corner.
  const float dx_max = std::max(working.cx, static_cast<float>(working.width - 1) - working.cx);
  const float dy_max = std::max(working.cy, static_cast<float>(working.height - 1) - working.cy);
  const float inv_r2 = 1.0f / (dx_max * dx_max + dy_max * dy_max);
  const float inv_two_sigma2 = 1.0f / (2.0f * options.confidence_sigma * options.confidence_sigma);
  for (int y = 0; y < working.height; ++y)
    for (int x = 0; x < working.width; ++x) {
      const float dx = static_cast<float>(x) - working.cx, dy = static_cast<float>(y) - working.cy;
      f.weight_(x, y) = fusion_math::confidence_weight((dx * dx + dy * dy) * inv_r2, inv_two_sigma2);
    }
  return f;
}

void SurfelFusion::begin_frame() {
  std::memset(cell_state_.get(), 0, static_cast<std::size_t>(cells_));
  seen_count_ = 0;
  unmatched_count_ = 0;
}

void SurfelFusion::see(int32_t cell) {
  if (cell_state_[cell] & kSeen) return;
  cell_state_[cell] = kSeen;
  if (seen_count_ < seen_capacity_) seen_[seen_count_++] = cell;
}

// ---------------------------------------------------------------------------------------------
// Per pixel

// The measurement of one pixel (x, y), written once for make_pixel() and the row pass of
// associate(): whether it is valid (depth d > 0 and a valid level-0 normal n0), its vertex and the
// normal fusion uses, in the current camera. With coarse normals (kCoarse), n1 and cd are the normal
// and depth of the pixel's 2x2 block on the coarse level (zero where the block lies outside that
// level), and the normal is n1 when cd says the block is the same surface, else n0. Every value is
// computed whatever the validity and chosen by selects, so that a loop over a row has no branch; for
// an invalid pixel the vertex and normal are meaningless.
template <bool kCoarse>
inline bool SurfelFusion::measure(float x, float y, float d, const float* n0, const float* n1, float cd,
                                  Eigen::Vector3f* v, Eigen::Vector3f* n_c) const {
  const bool valid = (d > 0.0f) & valid_normal(Eigen::Vector3f(n0[0], n0[1], n0[2]));
  *v = K_.backproject(x, y, d);
  float nx = n0[0], ny = n0[1], nz = n0[2];
  if (kCoarse) {
    const bool take = valid_normal(Eigen::Vector3f(n1[0], n1[1], n1[2])) & (std::fabs(cd - d) <= depth_gate(d));
    nx = take ? n1[0] : nx;
    ny = take ? n1[1] : ny;
    nz = take ? n1[2] : nz;
  }
  *n_c = Eigen::Vector3f(nx, ny, nz);
  return valid;
}

float SurfelFusion::fused_depth(const FrameContext& fc, int x, int y, float* offset) const {
  const float d = fc.depth(x, y);
  *offset = 0.0f;
  if (options_.pixel_stride == 1) return d;
  const bool right = x + 1 < K_.width, below = y + 1 < K_.height;
  const fusion_math::CellDepth c =
      fusion_math::cell_depth(d, right ? fc.depth(x + 1, y) : 0.0f, below ? fc.depth(x, y + 1) : 0.0f,
                              right && below ? fc.depth(x + 1, y + 1) : 0.0f, depth_gate(d));
  *offset = c.offset;
  return c.depth;
}

bool SurfelFusion::make_pixel(const FrameContext& fc, int x, int y, PixelContext* px) const {
  float offset;
  const float d = fused_depth(fc, x, y, &offset);
  const float xm = static_cast<float>(x) + offset, ym = static_cast<float>(y) + offset;
  const float n0[3] = {fc.normal(x, y).x(), fc.normal(x, y).y(), fc.normal(x, y).z()};
  float n1[3] = {0.0f, 0.0f, 0.0f}, cd = 0.0f;
  bool valid;
  if (fc.coarse_normal.empty()) {
    valid = measure<false>(xm, ym, d, n0, n1, cd, &px->v, &px->n_c);
  } else {
    const int cx = x >> 1, cy = y >> 1;
    if (cx < fc.coarse_normal.width && cy < fc.coarse_normal.height) {
      const Eigen::Vector3f& c = fc.coarse_normal(cx, cy);
      n1[0] = c.x();
      n1[1] = c.y();
      n1[2] = c.z();
      cd = fc.coarse_depth(cx, cy);
    }
    valid = measure<true>(xm, ym, d, n0, n1, cd, &px->v, &px->n_c);
  }
  if (!valid) return false;
  px->x = x;
  px->y = y;
  px->n_w = fc.R_wc * px->n_c;
  return true;
}

// Every pixel of row y measured (measure()) and moved into the index map's camera, into the row
// buffers: the per-pixel arithmetic of association done for a whole row in one branch-free loop,
// which the compiler vectorises.
void SurfelFusion::prepare_row(const FrameContext& fc, int y) {
  if (options_.pixel_stride == 2) {
    // The fused (even) pixels' cell depths and offsets (fusion_math::cell_depth); the odd pixels'
    // entries keep their zeros and are never read. Scalar: GCC does not vectorise the cell test (it
    // keeps the comparisons as branches), and at 160 cells a row it is a small part of the row pass.
    const int w = K_.width;
    const float* d0 = fc.depth.row(y);
    const float* d1 = y + 1 < K_.height ? fc.depth.row(y + 1) : nullptr;
    float* out = row_field(kRowDepth);
    float* off = row_field(kRowOffset);
    for (int x = 0; x < w; x += 2) {
      const fusion_math::CellDepth c =
          x + 1 < w && d1 != nullptr
              ? fusion_math::cell_depth(d0[x], d0[x + 1], d1[x], d1[x + 1], depth_gate(d0[x]))
              : fusion_math::CellDepth{d0[x], 0.0f};
      out[x] = c.depth;
      off[x] = c.offset;
    }
  }
  if (fc.coarse_normal.empty()) {
    prepare_row<false>(fc, y);
    return;
  }
  // The coarse normal and depth of each pixel's 2x2 block, spread to the pixels (zero outside the
  // coarse level), so that the row pass reads them consecutively.
  const int w = K_.width;
  float* __restrict c1x = row_field(kRowC1x);
  float* __restrict c1y = row_field(kRowC1y);
  float* __restrict c1z = row_field(kRowC1z);
  float* __restrict cdep = row_field(kRowCd);
  const int cy = y >> 1;
  // Pixels 0 .. covered - 1 have their block on the coarse level.
  const int covered = cy < fc.coarse_normal.height ? std::min(w, 2 * fc.coarse_normal.width) : 0;
  const float* cn = fc.coarse_normal.row(std::min(cy, fc.coarse_normal.height - 1))->data();
  const float* cd = fc.coarse_depth.row(std::min(cy, fc.coarse_depth.height - 1));
  for (int x = 0; x < covered; ++x) {
    const int cx = x >> 1;
    c1x[x] = cn[3 * cx];
    c1y[x] = cn[3 * cx + 1];
    c1z[x] = cn[3 * cx + 2];
    cdep[x] = cd[cx];
  }
  for (int x = covered; x < w; ++x) c1x[x] = c1y[x] = c1z[x] = cdep[x] = 0.0f;
  prepare_row<true>(fc, y);
}

template <bool kCoarse>
void SurfelFusion::prepare_row(const FrameContext& fc, int y) {
  const int w = K_.width;
  // At pixel_stride 2 the cell depths and offsets of the pre-pass (prepare_row above), else the
  // pixel's own depth and the offsets' zeros (create() clears them; only the pre-pass writes them).
  const float* __restrict depth = options_.pixel_stride == 2 ? row_field(kRowDepth) : fc.depth.row(y);
  const float* __restrict offset = row_field(kRowOffset);
  const float* __restrict normal = fc.normal.row(y)->data();  // x, y, z of each pixel
  const float* __restrict c1x = row_field(kRowC1x);
  const float* __restrict c1y = row_field(kRowC1y);
  const float* __restrict c1z = row_field(kRowC1z);
  const float* __restrict cdep = row_field(kRowCd);
  float* __restrict valid_out = row_field(kRowValid);
  float* __restrict vx = row_field(kRowVx);
  float* __restrict vy = row_field(kRowVy);
  float* __restrict vz = row_field(kRowVz);
  float* __restrict ncx = row_field(kRowNcx);
  float* __restrict ncy = row_field(kRowNcy);
  float* __restrict ncz = row_field(kRowNcz);
  float* __restrict nwx = row_field(kRowNwx);
  float* __restrict nwy = row_field(kRowNwy);
  float* __restrict nwz = row_field(kRowNwz);
  float* __restrict pix = row_field(kRowPix);
  float* __restrict piy = row_field(kRowPiy);
  float* __restrict piz = row_field(kRowPiz);
  float* __restrict xi = row_field(kRowXi);
  float* __restrict yi = row_field(kRowYi);
  float* __restrict gate = row_field(kRowGate);
  float* __restrict pwx = row_field(kRowPwx);
  float* __restrict pwy = row_field(kRowPwy);
  float* __restrict pwz = row_field(kRowPwz);
  float* __restrict rad = row_field(kRowRadius);
  const Eigen::Matrix3f R_wc = fc.R_wc, R_ic = fc.R_ic;
  const Eigen::Vector3f t_ic = fc.t_ic;
  const Intrinsics Ki = fc.Ki;
  // The row buffers are this object's own and never alias the frame's images.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC ivdep
#endif
  for (int x = 0; x < w; ++x) {
    Eigen::Vector3f v, n_c;
    const float n1[3] = {kCoarse ? c1x[x] : 0.0f, kCoarse ? c1y[x] : 0.0f, kCoarse ? c1z[x] : 0.0f};
    const float o = offset[x];
    const bool valid = measure<kCoarse>(static_cast<float>(x) + o, static_cast<float>(y) + o, depth[x], normal + 3 * x, n1,
                                        kCoarse ? cdep[x] : 0.0f, &v, &n_c);
    const Eigen::Vector3f n_w = R_wc * n_c;
    const Eigen::Vector3f p_i = R_ic * v + t_ic;
    const float inv_z = 1.0f / p_i.z();  // used only where p_i.z() > 0
    Eigen::Vector3f p_w;
    float radius;
    sample_geometry(fc, v, n_c, &p_w, &radius);
    valid_out[x] = valid ? 1.0f : 0.0f;
    vx[x] = v.x();
    vy[x] = v.y();
    vz[x] = v.z();
    ncx[x] = n_c.x();
    ncy[x] = n_c.y();
    ncz[x] = n_c.z();
    nwx[x] = n_w.x();
    nwy[x] = n_w.y();
    nwz[x] = n_w.z();
    pix[x] = p_i.x();
    piy[x] = p_i.y();
    piz[x] = p_i.z();
    xi[x] = Ki.fx * p_i.x() * inv_z + Ki.cx;
    yi[x] = Ki.fy * p_i.y() * inv_z + Ki.cy;
    gate[x] = depth_gate(p_i.z());
    pwx[x] = p_w.x();
    pwy[x] = p_w.y();
    pwz[x] = p_w.z();
    rad[x] = radius;
  }
}

// The world position and disc radius of a measurement (vertex v, normal n_c, current camera); written
// once for sample_at() and the row pass.
inline void SurfelFusion::sample_geometry(const FrameContext& fc, const Eigen::Vector3f& v, const Eigen::Vector3f& n_c,
                                          Eigen::Vector3f* p, float* radius) const {
  *p = fc.R_wc * v + fc.t_wc;
  // v.norm() written as the square root of squaredNorm() (the same value), which GCC vectorises.
  const float cos_abs = std::fabs(n_c.dot(v)) / std::sqrt(v.squaredNorm());
  *radius = radius_scale_ * fusion_math::surfel_radius_m(v.z(), cos_abs, focal_, options_.max_radius_incidence_factor);
}

fusion_math::Sample SurfelFusion::sample_at(const FrameContext& fc, const PixelContext& px) const {
  Eigen::Vector3f p;
  float radius;
  sample_geometry(fc, px.v, px.n_c, &p, &radius);
  return sample_from(px, p, radius);
}

fusion_math::Sample SurfelFusion::sample_from(const PixelContext& px, const Eigen::Vector3f& p, float radius) const {
  fusion_math::Sample s;
  s.p = p;
  s.n = px.n_w;
  s.radius = radius;
  if (color_.empty()) {
    s.r = s.g = s.b = kGreyLevel;
  } else if (options_.pixel_stride == 1) {
    const Rgb8 c = color_(px.x, px.y);
    s.r = c.r;
    s.g = c.g;
    s.b = c.b;
  } else {
    // At stride 2 the surfel stands for its pixel's 2x2 cell (x..x+1, y..y+1, clipped at the
    // border): the cell's mean colour. One pixel's colour would sample the texture at half its
    // rate, and the predicted intensity the tracker aligns with would alias (measured on the
    // Kinect-like seed-7 scan, 150 frames: ATE 159 mm with the pixel's colour, 2.9 mm with the
    // cell's, 6.8 mm at stride 1; docs/results.md, issue 31).
    const int x1 = std::min(px.x + 1, K_.width - 1), y1 = std::min(px.y + 1, K_.height - 1);
    const Rgb8 c[4] = {color_(px.x, px.y), color_(x1, px.y), color_(px.x, y1), color_(x1, y1)};
    s.r = 0.25f * ((static_cast<float>(c[0].r) + c[1].r) + (static_cast<float>(c[2].r) + c[3].r));
    s.g = 0.25f * ((static_cast<float>(c[0].g) + c[1].g) + (static_cast<float>(c[2].g) + c[3].g));
    s.b = 0.25f * ((static_cast<float>(c[0].b) + c[1].b) + (static_cast<float>(c[2].b) + c[3].b));
  }
  s.weight = weight_(px.x, px.y);
  return s;
}

// Duplicates: close across the normal (within merge_max_distance_px pixel footprints at depth z),
// within a depth gate along it, similar normals and radii.
bool SurfelFusion::mergeable(const SurfelPool& pool, int64_t a, int64_t b, float z) const {
  if (options_.merge_max_distance_px <= 0.0f) return false;
  const Eigen::Vector3f na(pool.nx()[a], pool.ny()[a], pool.nz()[a]);
  const Eigen::Vector3f nb(pool.nx()[b], pool.ny()[b], pool.nz()[b]);
  if (na.dot(nb) < cos_merge_gate_) return false;
  const float ra = pool.radius()[a], rb = pool.radius()[b];
  if (std::max(ra, rb) > options_.merge_max_radius_ratio * std::min(ra, rb)) return false;
  const Eigen::Vector3f d(pool.x()[b] - pool.x()[a], pool.y()[b] - pool.y()[a], pool.z()[b] - pool.z()[a]);
  const float along = d.dot(na);
  const float across2 = d.squaredNorm() - along * along;
  const float max_across = options_.merge_max_distance_px * z / focal_;
  const float gate = depth_gate(z);
  return std::fabs(along) <= gate && across2 <= max_across * max_across;
}

namespace {

// The association order of two candidates that passed the gates: one not yet updated this frame
// before one that was, then the nearer to the ray (squared index-pixel distance d2), then the more
// confident. Preferring a fresh surfel lets two pixels that share a window find their two surfels.
inline bool candidate_better(bool updated, float d2, float conf, bool have_best, bool best_updated, float best_d2,
                             float best_conf) {
  if (!have_best) return true;
  if (updated != best_updated) return !updated;
  return d2 < best_d2 || (d2 == best_d2 && conf > best_conf);
}

// The index pixels c with lo <= c < lo + n are those whose centres lie in [centre - half, centre +
// half): exactly 2 * half of them, whatever the fraction of `centre` (a floor-based block would
// shift by one when the projection of a pixel centre lands on a half-integer and rounding noise
// decides, which it does at the pose the map was rendered from).
inline int window_start(float centre, float half) { return static_cast<int>(std::ceil(centre - half)); }

// Bit k set when ids[from + k] >= 0 (an occupied index cell), for from <= from + k < to, at most 32
// cells. Branch-free on purpose: most cells of a window are empty (7-Scenes at 320x240: 2.6 occupied
// of about 10 cells visited per pixel at scale 2, 1.9 of 20.5 at scale 4), in no pattern a branch
// predictor learns.
// Callers then visit the set bits in ascending order, the order a plain loop over the row has.
inline uint32_t occupied_cells(const int32_t* ids, int from, int to) {
  uint32_t bits = 0;
  for (int bx = from; bx < to; ++bx) bits |= static_cast<uint32_t>(ids[bx] >= 0) << (bx - from);
  return bits;
}

}  // namespace

// One pixel's candidates: the index pixels of its window, the gates, and the best by candidate_better.
struct SurfelFusion::WindowScan {
  struct Gated {
    int64_t id;
    int bx, by;    // its index pixel
    int32_t cell;  // the same as by * index width + bx
  };
  int best = -1;  // into gated
  bool best_updated = false;
  float best_d2 = 0, best_conf = 0;
  int n_gated = 0, n_candidates = 0, n_depth_ok = 0;
  Gated gated[kMaxWindow * kMaxWindow];
};

// The occupied index pixel (bx, by) as a candidate of pixel `px`: gated on the map's depth and its
// copy of the surfel's normal and confidence (slam/index_map.h), so that the pool is read only for a
// surfel this frame has updated already (its columns were just written, so they are in cache): every
// pixel sees each surfel as the pool holds it at that moment, as it would reading the pool alone.
inline void SurfelFusion::visit_cell(const FrameContext& fc, const IndexMap& index, const SurfelPool& pool,
                                     const PixelContext& px, int bx, int by, bool in_base, WindowScan* ws,
                                     FusionStats& st) {
  const int32_t cell = by * index.id.width() + bx;
  const int32_t id = index.id.data()[cell];
  if (id >= fc.pool_size) {
    ++st.invalid_index_ids;
    return;
  }
  see(cell);
  const uint8_t f = flags(cell);
  if (f & kMerged) return;
  ++ws->n_candidates;
  const float dz = index.depth.data()[cell] - px.p_i.z();  // > 0: the surfel is behind the measurement
  if (dz < -options_.free_space_gate_factor * px.gate) {
    // The sensor sees through it (judged in clean()); only for the pixel's own footprint.
    if (in_base) set_flag(cell, kViolated);
    return;
  }
  if (std::fabs(dz) > px.gate) return;
  ++ws->n_depth_ok;
  const bool updated = (f & kUpdated) != 0;
  const IndexSurface surface = updated ? IndexSurface{pool.nx()[id], pool.ny()[id], pool.nz()[id], pool.confidence()[id]}
                                       : index.surface.data()[cell];
  const float cos_n = surface.nx * px.n_w.x() + surface.ny * px.n_w.y() + surface.nz * px.n_w.z();
  if (cos_n < cos_normal_gate_) return;
  const float ex = static_cast<float>(bx) - px.xi, ey = static_cast<float>(by) - px.yi;
  const float d2 = ex * ex + ey * ey;
  const float conf = surface.confidence;
  if (candidate_better(updated, d2, conf, ws->best >= 0, ws->best_updated, ws->best_d2, ws->best_conf)) {
    ws->best = ws->n_gated;
    ws->best_updated = updated;
    ws->best_d2 = d2;
    ws->best_conf = conf;
  }
  ws->gated[ws->n_gated++] = WindowScan::Gated{id, bx, by, cell};
}

// The base block first; the margin only when no surfel of the block passes the gates (most pixels
// find theirs in the block, and the margin is 8 of the 9 cells of a 3x3 window at scale 1). A
// block whose passing surfels were all updated already leaves the pixel covered (FusionOptions::
// search_margin_index_px says why the margin is not searched for a fresher one).
void SurfelFusion::scan_window(const FrameContext& fc, const IndexMap& index, const SurfelPool& pool,
                               const PixelContext& px, WindowScan* ws, FusionStats& st) {
  if (scale_ == 1) {
    scan_unit_window(fc, index, pool, px, ws, st);
    return;
  }
  const int iw = index.id.width(), ih = index.id.height();
  const float half_scale = 0.5f * static_cast<float>(scale_);  // index pixels
  const int bx0 = window_start(px.xi, half_scale), by0 = window_start(px.yi, half_scale);
  const int bx1 = bx0 + scale_, by1 = by0 + scale_;  // exclusive
  for (int by = std::max(by0, 0); by < std::min(by1, ih); ++by) {
    const int32_t* ids = &index.id(0, by);
    // A window row streams through a map far larger than the caches (1280 x 960 x 24 bytes at
    // 320x240, scale 4), several rows at once, which the hardware prefetcher does not keep up with
    // (measured: about 20% of fuse() less with this). Fetch a few pixels ahead.
    if (bx0 + kPrefetchAhead < iw) {
      __builtin_prefetch(ids + bx0 + kPrefetchAhead);
      __builtin_prefetch(&index.depth(0, by) + bx0 + kPrefetchAhead);
      __builtin_prefetch(&index.surface(0, by) + bx0 + kPrefetchAhead);
    }
    // The surfel a pixel picks sits anywhere in the pool's columns, which fuse_sample() then reads
    // and writes: a cache miss per column once the pool outgrows the caches. The pixel
    // kSurfelPrefetchPixels to the right visits nearly the same rows kSurfelPrefetchPixels x scale
    // cells further on: fetch its candidates' columns now, so they have arrived when that pixel is
    // fused. Only hints: no result depends on them.
    const int ahead = std::max(bx0 + kSurfelPrefetchPixels * scale_, 0);
    for (uint32_t bits = occupied_cells(ids, ahead, std::min(ahead + scale_, iw)); bits != 0; bits &= bits - 1) {
      const int32_t id = ids[ahead + __builtin_ctz(bits)];
      if (id >= fc.pool_size) continue;
      __builtin_prefetch(pool.nx() + id);
      __builtin_prefetch(pool.ny() + id);
      __builtin_prefetch(pool.nz() + id);
      __builtin_prefetch(pool.confidence() + id);
      __builtin_prefetch(pool.radius() + id);
      __builtin_prefetch(pool.x() + id);
      __builtin_prefetch(pool.y() + id);
      __builtin_prefetch(pool.z() + id);
      __builtin_prefetch(pool.color() + id);
      __builtin_prefetch(pool.last_seen() + id);
    }
    const int from = std::max(bx0, 0);
    for (uint32_t bits = occupied_cells(ids, from, std::min(bx1, iw)); bits != 0; bits &= bits - 1)
      visit_cell(fc, index, pool, px, from + __builtin_ctz(bits), by, true, ws, st);
  }
  const int margin = options_.search_margin_index_px;
  if (margin == 0 || ws->best >= 0) return;
  const int x0 = bx0 - margin, y0 = by0 - margin, x1 = bx1 + margin, y1 = by1 + margin;
  for (int by = std::max(y0, 0); by < std::min(y1, ih); ++by) {
    const int32_t* ids = &index.id(0, by);
    // Rows through the block visit [x0, bx0) and [bx1, x1); the others [x0, x1).
    const bool base_row = by >= by0 && by < by1;
    const int gap_from = base_row ? bx0 : x1, gap_to = base_row ? bx1 : x1;
    const int left = std::max(x0, 0), right = std::max(gap_to, 0);
    for (uint32_t bits = occupied_cells(ids, left, std::min(gap_from, iw)); bits != 0; bits &= bits - 1)
      visit_cell(fc, index, pool, px, left + __builtin_ctz(bits), by, false, ws, st);
    for (uint32_t bits = occupied_cells(ids, right, std::min(x1, iw)); bits != 0; bits &= bits - 1)
      visit_cell(fc, index, pool, px, right + __builtin_ctz(bits), by, false, ws, st);
  }
}

// scan_window at index scale 1 (the default): the base block is the one cell nearest the pixel's
// projection and the margin the cells around it. The same cells in the same order (rows ascending,
// each row's cells ascending) as the general loop, which they must match visit for visit
// (candidate_better breaks ties by order), without the block loops and occupancy masks that cost
// more than one cell's visit (7-Scenes, bench_slam_stages, alternating runs: associate 5.20 -> 5.07
// ms; trajectory and map byte-identical). No prefetches: at this scale the surfels of neighbouring
// pixels are neighbours in the pool (slam/spatial_order.h), and fetching them ahead measured no faster.
void SurfelFusion::scan_unit_window(const FrameContext& fc, const IndexMap& index, const SurfelPool& pool,
                                    const PixelContext& px, WindowScan* ws, FusionStats& st) {
  const int iw = index.id.width(), ih = index.id.height();
  const int bx0 = window_start(px.xi, 0.5f), by0 = window_start(px.yi, 0.5f);
  const int32_t* ids = index.id.data();
  if (bx0 >= 0 && bx0 < iw && by0 >= 0 && by0 < ih && ids[by0 * iw + bx0] >= 0)
    visit_cell(fc, index, pool, px, bx0, by0, true, ws, st);
  const int margin = options_.search_margin_index_px;
  if (margin == 0 || ws->best >= 0) return;
  const int x0 = std::max(bx0 - margin, 0), x1 = std::min(bx0 + 1 + margin, iw);
  const int y0 = std::max(by0 - margin, 0), y1 = std::min(by0 + 1 + margin, ih);
  for (int by = y0; by < y1; ++by) {
    const int32_t* row = ids + by * iw;
    for (int bx = x0; bx < x1; ++bx)
      if (row[bx] >= 0 && (bx != bx0 || by != by0)) visit_cell(fc, index, pool, px, bx, by, false, ws, st);
  }
}

// scan_unit_window at margin 1 for a pixel that projects into its own index pixel, with the index
// map's tests of its 3x3 cells precomputed for the whole row (kernels/fusion_gates.h: `code`): the
// same visits in the same order, the same counts, flags and choice. What the row pass cannot know is
// this frame's own state: cells whose surfel was merged (no candidate) or updated (gated on the
// pool's values, as visit_cell does); those are looked at here, one cell at a time. Measured on
// 7-Scenes (bench_slam_stages, side by side): see docs/results.md, issue 31.
void SurfelFusion::scan_gated(const IndexMap& index, const SurfelPool& pool, const PixelContext& px, uint32_t code,
                              WindowScan* ws) {
  using kernels::kGateOwnCell;
  const uint32_t occupied = code & kernels::kGateCells;
  if (occupied == 0) return;  // no candidate: the pixel is unmatched (empty)
  // Everything in locals: the flags are bytes, and a store through a byte pointer may alias anything,
  // which would make the compiler reload every member and counter after each one.
  uint8_t* const state = cell_state_.get();
  int32_t* const seen = seen_.get();
  int64_t seen_count = seen_count_;
  const int64_t seen_capacity = seen_capacity_;
  const int32_t* const ids = index.id.data();
  const IndexSurface* const surfaces = index.surface.data();
  const float* const pnx = pool.nx();
  const float* const pny = pool.ny();
  const float* const pnz = pool.nz();
  const float* const pconf = pool.confidence();
  const float nwx = px.n_w.x(), nwy = px.n_w.y(), nwz = px.n_w.z(), xi = px.xi, yi = px.yi;
  const float cos_gate = cos_normal_gate_;
  const int x = px.x, y = px.y, iw = index.id.width();
  const int32_t own = y * iw + x;
  const uint32_t depth_code = code >> kernels::kGateDepthShift, normal_code = code >> kernels::kGateNormalShift;
  int n_candidates = 0, n_depth_ok = 0, n_gated = 0, best = -1;
  bool best_updated = false;
  float best_d2 = 0, best_conf = 0;
  WindowScan::Gated* const gated = ws->gated;
  // see(): the first visit of a cell this frame lists it.
  const auto visit = [&](int32_t cell) {
    const uint8_t f = state[cell];
    if (!(f & kSeen)) {
      state[cell] = static_cast<uint8_t>(f | kSeen);
      if (seen_count < seen_capacity) seen[seen_count++] = cell;
    }
    return f;
  };
  // An updated surfel is gated on its normal as fused this frame (visit_cell).
  const auto normal_ok = [&](int32_t cell, bool upd, bool static_ok) {
    if (!upd) return static_ok;
    const int32_t id = ids[cell];
    const float cos_n = pnx[id] * nwx + pny[id] * nwy + pnz[id] * nwz;
    return !(cos_n < cos_gate);
  };
  const auto choose = [&](int k, int32_t cell, bool upd) {
    const int32_t id = ids[cell];
    const int bx = x + k % 3 - 1, by = y + k / 3 - 1;
    const float ex = static_cast<float>(bx) - xi, ey = static_cast<float>(by) - yi;
    const float d2 = ex * ex + ey * ey;
    const float conf = upd ? pconf[id] : surfaces[cell].confidence;
    if (candidate_better(upd, d2, conf, best >= 0, best_updated, best_d2, best_conf)) {
      best = n_gated;
      best_updated = upd;
      best_d2 = d2;
      best_conf = conf;
    }
    gated[n_gated++] = WindowScan::Gated{id, bx, by, cell};
  };
  bool own_passes = false;
  if (occupied & kGateOwnCell) {  // the own cell first
    const uint8_t f = visit(own);
    if (!(f & kMerged)) {
      ++n_candidates;
      if (code & kernels::kGateOwnViolated) {
        state[own] = static_cast<uint8_t>(state[own] | kViolated);
      } else if (depth_code & kGateOwnCell) {
        ++n_depth_ok;
        const bool upd = (f & kUpdated) != 0;
        own_passes = normal_ok(own, upd, (normal_code & kGateOwnCell) != 0);
        if (own_passes) choose(4, own, upd);
      }
    }
  }
  if (!own_passes) {  // the margin only when the own cell has no passing candidate
    const int32_t offset[9] = {-iw - 1, -iw, -iw + 1, -1, 0, 1, iw - 1, iw, iw + 1};  // cell k - own
    for (uint32_t bits = occupied & ~kGateOwnCell; bits != 0; bits &= bits - 1) {
      const int k = __builtin_ctz(bits);
      const int32_t cell = own + offset[k];
      const uint8_t f = visit(cell);
      if (f & kMerged) continue;
      ++n_candidates;
      if (!((depth_code >> k) & 1u)) continue;
      ++n_depth_ok;
      const bool upd = (f & kUpdated) != 0;
      if (normal_ok(cell, upd, ((normal_code >> k) & 1u) != 0)) choose(k, cell, upd);
    }
  }
  seen_count_ = seen_count;
  ws->n_candidates = n_candidates;
  ws->n_depth_ok = n_depth_ok;
  ws->n_gated = n_gated;
  ws->best = best;
  ws->best_updated = best_updated;
  ws->best_d2 = best_d2;
  ws->best_conf = best_conf;
}

// Duplicates among one pixel's gated candidates merge into the more confident of each pair, starting
// from the surfel the pixel was fused into.
void SurfelFusion::merge_duplicates(SurfelPool& pool, const WindowScan& ws, float z, FusionStats& st) {
  const float max_cells = options_.merge_max_distance_px * static_cast<float>(scale_);  // index pixels
  // Candidates lie in distinct index pixels (one surfel each), at least one pixel apart: below one
  // pixel (index scale 1, the default) no pair can merge.
  if (max_cells < 1.0f || ws.n_gated < 2) return;
  WindowScan::Gated keep = ws.gated[ws.best];
  for (int k = 0; k < ws.n_gated; ++k) {
    const WindowScan::Gated& other = ws.gated[k];
    if (other.id == keep.id || (flags(other.cell) & kMerged)) continue;
    if (std::abs(other.bx - keep.bx) > max_cells || std::abs(other.by - keep.by) > max_cells) continue;
    if (!mergeable(pool, keep.id, other.id, z)) continue;
    const bool swap = pool.confidence()[other.id] > pool.confidence()[keep.id];
    const WindowScan::Gated into = swap ? other : keep, from = swap ? keep : other;
    fusion_math::merge_into(pool, into.id, from.id);
    set_flag(from.cell, kMerged);
    set_flag(into.cell, kUpdated);
    ++st.merged;
    keep = into;
  }
}

// Steps 1 and 2 (surfel_fusion.h).
void SurfelFusion::associate(const FrameContext& fc, const IndexMap& index, SurfelPool& pool, int32_t frame_index,
                             FusionStats& st) {
  const int w = K_.width, h = K_.height;
  PixelContext px;
  WindowScan ws;
  const float* r = row_.get();
  const auto field = [&](int f, int x) { return r[f * w + x]; };
  // The row pass of the gates (kernels/fusion_gates.h) at index scale 1 and margin 1 (the defaults),
  // for the pixels whose 3x3 cells lie inside the map; the border pixels take scan_window.
  const bool gated_rows = options_.row_gates && fc.has_index && scale_ == 1 && options_.search_margin_index_px == 1 &&
                          w >= 3 && h >= 3;
  kernels::FusionGateParams gp;
  gp.pool_size = static_cast<int32_t>(fc.pool_size);
  gp.neg_free_space_factor = -options_.free_space_gate_factor;
  gp.cos_normal_gate = cos_normal_gate_;
  kernels::FusionGateRow gr;
  gr.xi = r + kRowXi * w;
  gr.yi = r + kRowYi * w;
  gr.z = r + kRowPiz * w;
  gr.gate = r + kRowGate * w;
  gr.nwx = r + kRowNwx * w;
  gr.nwy = r + kRowNwy * w;
  gr.nwz = r + kRowNwz * w;
  uint32_t* code = gate_code_.get();
  // Counters in locals, written back at the end: the state flags are bytes, whose stores may alias
  // anything, so a counter kept in `st` would be reloaded and stored again around every one.
  int64_t valid = 0, unmatched_empty = 0, unmatched_depth = 0, unmatched_normal = 0, covered = 0, fused = 0;
  int64_t confirmed = 0, row_gated = 0, n_unmatched = unmatched_count_;
  int32_t* const unmatched = unmatched_.get();
  const int stride = options_.pixel_stride;
  for (int y = 0; y < h; y += stride) {
    prepare_row(fc, y);
    const bool gated_row = gated_rows && y >= 1 && y < h - 1;
    if (gated_row) {
      gp.y = y;
      for (int k = 0; k < 3; ++k) {
        gp.id[k] = &index.id(0, y + k - 1);
        gp.depth[k] = &index.depth(0, y + k - 1);
        gp.surface[k] = &index.surface(0, y + k - 1).nx;
      }
      kernels::fusion_gates(gp, gr, 1, w - 1, code);
    }
    for (int x = 0; x < w; x += stride) {
      if (field(kRowValid, x) == 0.0f) continue;
      ++valid;
      const int32_t pixel_index = y * w + x;
      px.x = x;
      px.y = y;
      px.v = Eigen::Vector3f(field(kRowVx, x), field(kRowVy, x), field(kRowVz, x));
      px.n_c = Eigen::Vector3f(field(kRowNcx, x), field(kRowNcy, x), field(kRowNcz, x));
      px.n_w = Eigen::Vector3f(field(kRowNwx, x), field(kRowNwy, x), field(kRowNwz, x));
      px.p_i = Eigen::Vector3f(field(kRowPix, x), field(kRowPiy, x), field(kRowPiz, x));
      if (!fc.has_index || !(px.p_i.z() > 0.0f)) {
        unmatched[n_unmatched++] = pixel_index;
        ++unmatched_empty;
        continue;
      }
      px.xi = field(kRowXi, x);
      px.yi = field(kRowYi, x);
      px.gate = field(kRowGate, x);
      ws.best = -1;
      ws.n_gated = ws.n_candidates = ws.n_depth_ok = 0;
      const bool fast = gated_row && x >= 1 && x < w - 1 &&
                        (code[x] & (kernels::kGateIdentity | kernels::kGateInvalid)) == kernels::kGateIdentity;
      if (fast) {
        scan_gated(index, pool, px, code[x], &ws);
        ++row_gated;
      } else {
        scan_window(fc, index, pool, px, &ws, st);
      }
      if (ws.best < 0) {
        unmatched[n_unmatched++] = pixel_index;
        ++(ws.n_candidates == 0 ? unmatched_empty : ws.n_depth_ok == 0 ? unmatched_depth : unmatched_normal);
        continue;
      }
      if (ws.best_updated) {
        ++covered;
        continue;
      }
      const WindowScan::Gated& best = ws.gated[ws.best];
      const fusion_math::Sample sample =
          sample_from(px, Eigen::Vector3f(field(kRowPwx, x), field(kRowPwy, x), field(kRowPwz, x)), field(kRowRadius, x));
      if (!fusion_math::fuse_sample(pool, best.id, sample, options_.max_radius_growth, frame_index)) ++confirmed;
      set_flag(best.cell, kUpdated);
      ++fused;
      merge_duplicates(pool, ws, px.p_i.z(), st);
    }
  }
  unmatched_count_ = n_unmatched;
  st.valid_pixels += valid;
  st.unmatched_empty += unmatched_empty;
  st.unmatched_depth += unmatched_depth;
  st.unmatched_normal += unmatched_normal;
  st.covered_pixels += covered;
  st.fused_pixels += fused;
  st.confirmed_only += confirmed;
  st.row_gated_pixels += row_gated;
}

// Step 3: decide over the seen surfels and one sweep's worth of ids, then swap-remove from high ids
// to low (the surfel moved into a freed slot always comes from above it and is never to be removed).
void SurfelFusion::clean(const IndexMap& index, SurfelPool& pool, int32_t frame_index, FusionStats& st) {
  const float stable = options_.stable_confidence;
  const int64_t lifetime = options_.unstable_lifetime_frames;
  const auto too_old = [&](int64_t id) {
    return pool.confidence()[id] < stable && static_cast<int64_t>(frame_index) - pool.init_time()[id] > lifetime;
  };
  // The sweep covers ids cursor, cursor + 1, ... (wrapping at the pool's size); a seen surfel among
  // them is decided by the first loop and marked here so that the sweep passes over it.
  const int64_t size = pool.size();
  const int64_t sweep = std::min<int64_t>(options_.lifetime_sweep_per_frame, size);
  if (sweep_cursor_ >= size) sweep_cursor_ = 0;
  std::fill(sweep_decided_.get(), sweep_decided_.get() + sweep_words(sweep), uint64_t{0});

  int64_t out = 0;  // ids to remove are compacted to the front of seen_ (which held index pixels)
  for (int64_t k = 0; k < seen_count_; ++k) {
    const int32_t cell = seen_[k];
    const int32_t id = index.id.data()[cell];
    const uint8_t f = flags(cell);
    int64_t offset = id - sweep_cursor_;
    if (offset < 0) offset += size;
    if (offset < sweep) sweep_decided_[offset >> 6] |= uint64_t{1} << (offset & 63);
    bool remove = false;
    if (f & kMerged) {
      remove = true;  // counted in st.merged when merged
    } else if ((f & kViolated) && !(f & kUpdated)) {
      if (pool.confidence()[id] < stable) {
        remove = true;
        ++st.removed_free_space;
      } else {
        pool.confidence()[id] -= options_.free_space_penalty;
        ++st.demoted_free_space;
      }
    } else if (too_old(id)) {
      remove = true;
      ++st.removed_stale;
    }
    if (remove) seen_[out++] = id;
  }

  for (int64_t k = 0; k < sweep; ++k) {
    const int64_t id = sweep_cursor_;
    if (++sweep_cursor_ >= size) sweep_cursor_ = 0;
    if ((sweep_decided_[k >> 6] >> (k & 63)) & 1) continue;  // decided above
    if (too_old(id)) {
      seen_[out++] = static_cast<int32_t>(id);
      ++st.removed_stale;
    }
  }

  std::sort(seen_.get(), seen_.get() + out, std::greater<int32_t>());
  // The predictor puts a surfel into one index pixel only; an index map made otherwise that lists
  // an id twice must still not remove it twice.
  for (int64_t k = 0; k < out; ++k)
    if (k == 0 || seen_[k] != seen_[k - 1]) pool.remove(seen_[k]);
}

// Step 4: new surfels for the unmatched pixels, as many as the pool admits, spread over the image.
void SurfelFusion::create_new(const FrameContext& fc, SurfelPool& pool, int32_t frame_index, FusionStats& st) {
  const int64_t wanted = unmatched_count_;
  if (wanted == 0) return;
  const uint64_t evicted_before = pool.counters().evicted;
  const int64_t allowed = pool.reserve_for_new(wanted, frame_index, options_.stable_confidence);
  st.evicted = static_cast<int64_t>(pool.counters().evicted - evicted_before);
  if (allowed < wanted) {
    st.refused = wanted - allowed;
    pool.count_refused(static_cast<uint64_t>(st.refused));
  }
  PixelContext px;
  int64_t taken = 0;
  for (int64_t k = 0; k < wanted && taken < allowed; ++k) {
    // Pixel k is admitted when floor((k + 1) allowed / wanted) steps up: `allowed` evenly spaced ones.
    if ((k + 1) * allowed / wanted == k * allowed / wanted) continue;
    const int32_t pixel = unmatched_[k];
    if (!make_pixel(fc, pixel % K_.width, pixel / K_.width, &px)) continue;  // cannot happen
    const fusion_math::Sample s = sample_at(fc, px);
    const int64_t id = pool.append(s.p.x(), s.p.y(), s.p.z(), s.n.x(), s.n.y(), s.n.z(), s.radius, s.weight,
                                   pack_rgb(fusion_math::to_u8(s.r), fusion_math::to_u8(s.g), fusion_math::to_u8(s.b)),
                                   frame_index);
    if (id < 0) break;  // reserve_for_new said there was room: not reached
    ++taken;
  }
  st.new_surfels = taken;
}

Status SurfelFusion::fuse(const Preprocessor& frame, ImageView<const Rgb8> color, const SE3& T_world_cam,
                          const IndexMap& index, int32_t frame_index, SurfelPool* pool, FusionStats* stats) {
  const Clock::time_point t_start = Clock::now();
  if (pool == nullptr || stats == nullptr)
    return error(ErrorCode::kInvalidArgument, "surfel fusion: null pool or stats");
  const Intrinsics& Kf = frame.intrinsics();
  if (Kf.width != K_.width || Kf.height != K_.height)
    return error(ErrorCode::kInvalidArgument, "surfel fusion: frame is " + std::to_string(Kf.width) + "x" +
                                                  std::to_string(Kf.height) + ", fusion was created for " +
                                                  std::to_string(K_.width) + "x" + std::to_string(K_.height));
  if (!color.empty() && (color.width != K_.width || color.height != K_.height))
    return error(ErrorCode::kInvalidArgument, "surfel fusion: colour image size differs from the depth");
  if (pool->capacity() > capacity_)
    return error(ErrorCode::kInvalidArgument, "surfel fusion: pool capacity " + std::to_string(pool->capacity()) +
                                                  " exceeds the " + std::to_string(capacity_) + " given at create()");
  if (options_.normal_level >= frame.levels())
    return error(ErrorCode::kInvalidArgument, "surfel fusion: normal_level " + std::to_string(options_.normal_level) +
                                                  " needs a Preprocessor with more than " +
                                                  std::to_string(frame.levels()) + " levels");
  const bool has_index = !index.id.empty() && pool->size() > 0;
  if (!index.id.empty()) {
    const int iw = K_.width * scale_, ih = K_.height * scale_;
    if (index.scale != scale_ || index.id.width() != iw || index.id.height() != ih || index.depth.width() != iw ||
        index.depth.height() != ih || !index.intrinsics.valid())
      return error(ErrorCode::kInvalidArgument,
                   "surfel fusion: index map is scale " + std::to_string(index.scale) + ", " +
                       std::to_string(index.id.width()) + "x" + std::to_string(index.id.height()) +
                       "; expected scale " + std::to_string(scale_) + ", " + std::to_string(iw) + "x" +
                       std::to_string(ih));
    if (index.surface.width() != iw || index.surface.height() != ih)
      return error(ErrorCode::kInvalidArgument,
                   "surfel fusion: index map has " + std::to_string(index.surface.width()) + "x" +
                       std::to_string(index.surface.height()) + " surfaces for " + std::to_string(iw) + "x" +
                       std::to_string(ih) + " ids (slam/index_map.h: copy_surfaces_from_pool)");
  }

  *stats = FusionStats{};
  begin_frame();
  color_ = color;

  FrameContext fc;
  const Eigen::Matrix4d T_wc = T_world_cam.matrix();
  const Eigen::Matrix4d T_ic = (index.T_world_cam.inverse() * T_world_cam).matrix();
  fc.R_wc = T_wc.topLeftCorner<3, 3>().cast<float>();
  fc.t_wc = T_wc.topRightCorner<3, 1>().cast<float>();
  fc.R_ic = T_ic.topLeftCorner<3, 3>().cast<float>();
  fc.t_ic = T_ic.topRightCorner<3, 1>().cast<float>();
  fc.Ki = index.intrinsics;
  fc.has_index = has_index;
  fc.depth = options_.fuse_raw_depth ? frame.raw_depth() : frame.level(0).depth.view();
  fc.normal = frame.level(0).normal.view();
  if (options_.normal_level == 1) {
    fc.coarse_normal = frame.level(1).normal.view();
    fc.coarse_depth = frame.level(1).depth.view();
  }
  fc.pool_size = pool->size();

  Clock::time_point t0 = Clock::now();
  associate(fc, index, *pool, frame_index, *stats);
  stats->seen_surfels = seen_count_;
  stats->associate_ms = ms_since(t0);

  t0 = Clock::now();
  clean(index, *pool, frame_index, *stats);
  stats->clean_ms = ms_since(t0);

  t0 = Clock::now();
  create_new(fc, *pool, frame_index, *stats);
  stats->create_ms = ms_since(t0);

  color_ = ImageView<const Rgb8>();
  stats->total_ms = ms_since(t_start);
  return Status::success();
}

}  // namespace ef::slam
