// A picture of a surfel map (issue 33): what `run` writes as preview.png at the end and
// `edgefusion view` draws for any map. Two panels side by side, drawn from the same viewpoint: the
// surfels' own colours, and their most likely class in the paper's palette (core/classes.h), each
// shaded by its normal; the camera's path over both (green start, red end); below, a legend of the
// classes the map holds, with their share of the surfels.
//
// The viewpoint frames the map: by default oblique, from above and behind the direction the camera
// mostly looked (35 degrees down), or straight down (`top`); "up" is the mean of the camera's up
// axes over the trajectory (a hand-held or robot camera stays about upright), else the first
// camera's. The extent is the 2nd..98th percentile of the surfel centres, so a few stray surfels do
// not shrink the picture. Or an explicit camera pose and intrinsics.
//
// The renderer is a z-buffered splatter of each surfel as a disc of its radius (at least a pixel),
// written for pictures, not for tracking (slam/model_prediction is the tracker's). A MapPreviewer
// holds every large buffer from its construction (map_preview_bytes_for: the memory plan's "map
// preview" part), so `run` draws the preview at each checkpoint and at the end with the one it made
// at start-up; a drawing then allocates only the few small blocks of OpenCV's text drawing.
// The free functions below make a previewer per call (`view`, tests).
//
// Threads: a MapPreviewer is used by one thread at a time (run: the mapping thread).
#pragma once

#include <algorithm>
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/types.hpp>

#include "core/classes.h"
#include "core/image.h"
#include "core/intrinsics.h"
#include "core/result.h"
#include "core/se3.h"
#include "io/ply_writer.h"

namespace ef {
class PngEncoder;  // io/png_encoder.h
}

namespace ef::pipeline {

inline constexpr std::size_t kPreviewPathPoses = 4096;  // camera centres kept for the drawn path
inline constexpr int kPreviewWidth = 640, kPreviewHeight = 480;  // each panel of a run's preview.png

struct PreviewOptions {
  int width = 640, height = 480;         // each panel, pixels
  bool top = false;                      // straight down instead of oblique
  std::optional<SE3> pose;               // an explicit camera (T_world_cam), with `intrinsics` or
  std::optional<Intrinsics> intrinsics;  //   a 60-degree horizontal field of view
  std::string title;                     // written at the top left (the run, the source)
};

// The camera a preview draws from (the framing above).
struct PreviewCamera {
  SE3 T_world_cam;
  Intrinsics intrinsics;
};
PreviewCamera frame_map(const SurfelCloudView& cloud, const std::vector<SE3>& trajectory, const PreviewOptions& options);

// What a preview drew, for messages and tests.
struct PreviewStats {
  int64_t surfels = 0;       // in the map
  int64_t drawn = 0;         // in front of the camera and inside the image
  int64_t covered_pixels = 0;  // pixels of a panel with a surfel
  std::array<int64_t, kNumClassesWithUnknown> class_counts{};  // surfels per class id 0..13
};

// The camera centres of a TUM trajectory file for the path drawn, at most `max_poses` of them
// (rounded up to an even number, at least 2: a long run's every k-th, k doubling as the file goes
// on, so memory stays bounded whatever its length; PreviewPath below samples it); "# lost" lines
// and comments skipped. Errors: the file cannot be opened.
Result<std::vector<SE3>> read_preview_path(const std::string& tum_file, std::size_t max_poses = kPreviewPathPoses);

// Bytes a previewer of panels width x height holds (depth buffers, the picture, framing samples,
// the path, the PNG encoder and its output): the memory plan's "map preview" part.
std::size_t map_preview_bytes_for(int width, int height);

// A preview drawer with its buffers (see the top of this file).
class MapPreviewer {
 public:
  // Panels of width x height pixels (64..4096 each; checked by create()).
  static Result<std::unique_ptr<MapPreviewer>> create(int width, int height);
  ~MapPreviewer();
  MapPreviewer(const MapPreviewer&) = delete;
  MapPreviewer& operator=(const MapPreviewer&) = delete;

  // Draws the picture: (2 x width) x (height + legend) RGB, valid until the next call. `options`'
  // width and height are ignored (the previewer's own). Errors: an empty map.
  Result<ImageView<const Rgb8>> render(const SurfelCloudView& cloud, const std::vector<SE3>& trajectory,
                                       const PreviewOptions& options, PreviewStats* stats = nullptr);
  // render() written as a PNG, whole or not at all (io/durable_file.h); errors name the file.
  Status write(const std::string& path, const SurfelCloudView& cloud, const std::vector<SE3>& trajectory,
               const PreviewOptions& options, PreviewStats* stats = nullptr);

  int width() const { return width_; }
  int height() const { return height_; }

  struct Framing;  // the framing's sample columns (map_preview.cpp)

 private:
  MapPreviewer(int width, int height);
  int width_, height_;
  std::vector<float> depth_, light_;  // per panel pixel: nearest depth (m), its shading
  std::vector<int32_t> owner_;        // per panel pixel: the surfel drawn there, -1 none
  Image<Rgb8> picture_;               // the tallest picture (every class in the legend)
  std::unique_ptr<Framing> framing_;
  std::vector<cv::Point2f> path_px_;  // the path projected (pixels), at most kPreviewPathPoses
  std::unique_ptr<PngEncoder> png_;
  std::string png_bytes_;
};

// A camera path kept in memory as a run goes (for the checkpoints' previews): at most `capacity`
// poses (rounded up to an even number, at least 2), the whole run evenly sampled (full: every
// other one is dropped and only every 2k-th pose is taken from then on). read_preview_path reads a
// file through one, so the path kept while mapping and the same poses read back from the
// trajectory are the same, and a resumed run that adds its trajectory so far (add_file) goes on
// sampling as the uninterrupted run would. Reserved by the constructor or reserve(); add() never
// allocates. A default-constructed path holds nothing and add() ignores every pose.
class PreviewPath {
 public:
  PreviewPath() = default;
  explicit PreviewPath(std::size_t capacity) { reserve(capacity); }
  void reserve(std::size_t capacity);  // and empties the path
  void add(const SE3& T_world_cam);
  // add() for every pose line of a TUM trajectory file, in order. Errors: the file cannot be opened.
  Status add_file(const std::string& tum_file);
  const std::vector<SE3>& poses() const { return poses_; }
  static std::size_t rounded_capacity(std::size_t capacity) { return std::max<std::size_t>(2, capacity + (capacity & 1)); }
  static std::size_t bytes_for(std::size_t capacity) { return rounded_capacity(capacity) * sizeof(SE3); }

 private:
  std::vector<SE3> poses_;
  std::size_t capacity_ = 0, stride_ = 1, seen_ = 0;
};

// The picture: (2 x width) x (height + legend) RGB. Errors: an empty map, sizes out of 64..4096.
Result<Image<Rgb8>> render_map_preview(const SurfelCloudView& cloud, const std::vector<SE3>& trajectory,
                                       const PreviewOptions& options, PreviewStats* stats = nullptr);

// render_map_preview written as a PNG (io/image_codec.h); errors name the file.
Status write_map_preview(const std::string& path, const SurfelCloudView& cloud, const std::vector<SE3>& trajectory,
                         const PreviewOptions& options, PreviewStats* stats = nullptr);

}  // namespace ef::pipeline
