// Per-frame preprocessing for tracking and fusion, at the working resolution (320x240 by default):
// depth cut-off, edge-preserving (bilateral) depth filter, and 3-level pyramids of depth, vertex and
// normal maps, intensity and intensity gradients, as KinectFusion (Newcombe et al., ISMAR 2011,
// section 3.2 "Surface measurement") and ElasticFusion (Whelan et al., RSS 2015) prepare a frame.
//
// Conventions of every map (level l has the size and intrinsics Intrinsics::pyramid_level(l)):
//   depth      Image<float>            metres along the optical axis, 0 = invalid
//   vertex     Image<Eigen::Vector3f>  camera frame (x right, y down, z forward), metres;
//                                      invalid = (0, 0, 0), so `v.z() > 0` is the validity test
//                                      (zeros, not NaN: an invalid row fed to a reduction by mistake
//                                      adds nothing instead of poisoning the system)
//   normal     Image<Eigen::Vector3f>  unit length, pointing toward the camera (n . v < 0);
//                                      invalid = (0, 0, 0) (valid_normal() tests it)
//   intensity  Image<float>            grey levels 0..255 as float: 0.299 R + 0.587 G + 0.114 B of the
//                                      8-bit sRGB values (the scale of ElasticFusion's photometric terms)
//   grad_x/y   Image<float>            d intensity / d pixel (grey levels per pixel of that level):
//                                      3x3 Sobel divided by 8, so a ramp of slope s gives exactly s
//
// Memory: everything is allocated by Preprocessor::create(); process() never touches the heap.
// Threads: one Preprocessor per thread; process() and the accessors must not run concurrently.
#pragma once

#include <string>

#include <Eigen/Core>

#include "core/frame.h"
#include "core/image.h"
#include "core/intrinsics.h"
#include "core/options.h"
#include "core/result.h"

namespace ef::slam {

struct PreprocessOptions {
  // Pyramid levels including the working resolution; each level halves the previous one
  // (ElasticFusion: 3). Range 1..6; the coarsest level must stay at least 8x8 pixels.
  int levels = 3;
  // Depths beyond this (metres) are invalid. SemanticFusion uses 8 m (ElasticFusion's default is 3 m).
  float depth_cutoff_m = 8.0f;
  // Bilateral filter window radius, pixels of the working resolution: (2r+1)^2 taps, 2 -> 5x5.
  // 0 turns the filter off (level 0 depth is then the cut-off raw depth).
  int bilateral_radius_px = 2;
  // Spatial Gaussian sigma, pixels of the working resolution. ElasticFusion uses 4.5 px at 640x480,
  // which is 2.25 px at the default 320x240 (halve it again for 160x120).
  float bilateral_sigma_space_px = 2.25f;
  // Range Gaussian sigma, metres (KinectFusion / ElasticFusion: 30 mm). The kernel is evaluated as
  // (1 + t/8)^-8 with t = dd^2 / (2 sigma^2) (within 0.03 of exp(-t)): a neighbour across a 0.5 m step
  // gets a weight below 1e-10, so depths are not averaged across step edges.
  float bilateral_sigma_depth_m = 0.03f;
  // Depth pyramid: a coarse pixel averages the valid depths of its 4x4 neighbourhood (binomial
  // weights, centred on its 2x2 block) that lie within this distance (metres) of the mean depth of
  // the block's near surface; no valid depth in the block -> invalid (slam/depth_pyramid.h, the rule
  // the predicted model's pyramid shares). KinectFusion: 3 sigma_depth.
  float pyramid_depth_threshold_m = 0.09f;
  // Normals: a neighbour is across a depth discontinuity (normal invalid) when its depth differs from
  // the centre's by more than what a surface seen at this grazing angle (degrees between surface and
  // viewing ray) would give over one pixel: z / (f * tan(angle)), f the focal length of that level in
  // pixels. 5 deg: 3.9 cm at 1 m on level 0 at 320x240 (f ~ 292 px for a Kinect); a 0.5 m step is a
  // discontinuity up to ~12 m on level 0 and ~3 m on level 2.
  float normal_min_grazing_deg = 5.0f;

  // The keys `run` offers (section mapping): depth_cutoff_m.
  static const opt::Table<PreprocessOptions>& table();
  // An error naming the first field out of range.
  Status validate() const;
  // One line per field with its unit, for logs.
  std::string describe() const;
};

// Milliseconds spent by the last process() call, per stage (steady clock).
struct PreprocessTimings {
  double bilateral_ms = 0;      // cut-off, padding and the bilateral filter (level 0)
  double depth_pyramid_ms = 0;  // depth levels 1..L-1
  double vertex_normal_ms = 0;  // vertex and normal maps, every level
  double intensity_ms = 0;      // grey conversion, intensity pyramid and gradients, every level
  double total_ms = 0;
};

struct PyramidLevel {
  Intrinsics intrinsics;          // of this level
  Image<float> depth;             // level 0: bilateral-filtered; coarser: downsampled from the level above
  Image<Eigen::Vector3f> vertex;  // from `depth` and `intrinsics` (Intrinsics::backproject)
  Image<Eigen::Vector3f> normal;  // central differences of `vertex`
  Image<float> intensity;         // level 0 from colour; coarser: 4x4 binomial [1 3 3 1]/8, decimated
  Image<float> grad_x, grad_y;    // Sobel / 8 of `intensity`, borders replicated
};

// Grey level 0..255 of an 8-bit sRGB colour, the weights of `intensity` above.
inline float grey_level(uint8_t r, uint8_t g, uint8_t b) {
  return 0.299f * static_cast<float>(r) + 0.587f * static_cast<float>(g) + 0.114f * static_cast<float>(b);
}

inline bool valid_vertex(const Eigen::Vector3f& v) { return v.z() > 0.0f; }
// Evaluated without short circuit (`|`), so that loops calling it can stay branch-free and vectorise.
inline bool valid_normal(const Eigen::Vector3f& n) { return (n.x() != 0.0f) | (n.y() != 0.0f) | (n.z() != 0.0f); }

class Preprocessor {
 public:
  // Allocates every buffer for frames of working.width x working.height. Errors: invalid options,
  // invalid intrinsics, or a working size too small for the number of levels.
  static Result<Preprocessor> create(const Intrinsics& working, const PreprocessOptions& options = {});

  // Processes one frame already at the working resolution (io/frame_resample.h gets it there).
  // depth: metres, 0 = invalid (NaN, negative and beyond-cut-off values count as invalid too).
  // color: sRGB, same size, or empty (no colour: intensities and gradients are all 0 and
  // has_intensity() is false). Errors (kInvalidArgument): sizes that do not match the working size.
  // No heap allocation on success.
  Status process(ImageView<const float> depth, ImageView<const Rgb8> color);
  Status process(const Frame& frame) { return process(frame.depth.view(), frame.color.view()); }

  int levels() const { return options_.levels; }
  const PyramidLevel& level(int l) const { return levels_[l]; }
  // Level-0 depth after the cut-off, before the bilateral filter (metres, 0 = invalid): what fusion
  // may prefer to integrate. Overwritten by the next process().
  ImageView<const float> raw_depth() const;
  bool has_intensity() const { return has_intensity_; }
  const PreprocessTimings& timings() const { return timings_; }
  const PreprocessOptions& options() const { return options_; }
  const Intrinsics& intrinsics() const { return levels_[0].intrinsics; }
  // Bytes create() allocated: the levels' images and the filter's buffers (the memory plan).
  std::size_t bytes() const;
  // The same for a width x height working image before creating one (levels halve, rounding down).
  static std::size_t bytes_for(int width, int height, const PreprocessOptions& options);

 private:
  Preprocessor() = default;
  void cut_off_and_pad(ImageView<const float> depth);
  void bilateral();
  void vertex_normal(int l);
  void grey(ImageView<const Rgb8> color);
  void downsample_intensity(int l);
  void gradients(int l);

  PreprocessOptions options_;
  PyramidLevel levels_[6];
  Image<float> raw_depth_;        // level 0 after the cut-off, metres, 0 = invalid
  Image<float> padded_;           // the same with a border of bilateral_radius_px; invalid = sentinel
  Image<float> spatial_weights_;  // (2r+1) x (2r+1) Gaussian of the pixel offset
  float range_scale_ = 0;         // 1 / (2 sigma_depth^2), per m^2
  bool has_intensity_ = false;
  PreprocessTimings timings_;
};

}  // namespace ef::slam
