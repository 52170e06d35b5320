// The built-in synthetic frame source:
// "synthetic:<room>?seed=&trajectory=&frames=&size=&noise=&camera=&layout=&depth_bias=".
//
//   room        "" (the default, living_room), a built-in room (synthetic_room_names()), or
//               "random" (a room drawn from `seed`)
//   seed        unsigned integer, default 0: the random room, the trajectory's shape and wobble,
//               and the sensor noise
//   trajectory  loop (hand-held, default) | robot (planar, 0.3-0.6 m high) | inspect (the loop,
//               turning to the near wall and back: every place seen from across the room and close)
//   frames      positive integer, default 300; timestamps are index / 30 s
//   size        WxH, default 640x480 (Kinect-like fx = fy = 525, scaled for other sizes)
//   noise       1 (default: Kinect-like depth and colour noise) | 0 (exact images)
//   camera      ideal (default: the renderer's colour, plus the colour noise above) | kinect (the
//               colour camera of camera_model.h: motion blur, vignetting, auto-exposure, white
//               balance, shot noise; with noise=0 everything but the random noise)
//   layout      walls (default: furniture along the walls, the middle free) | island (also one
//               group of furniture in the middle, which the hand-held loop circles and which hides
//               a different part of the room in every view; room_builder.h)
//   depth_bias  a fraction -0.2..0.2, default 0: depth bent by 1 + depth_bias x r^2 towards the
//               corners (synth/depth_noise.h apply_depth_bias), a slow drift for loop closure to remove
// Frames carry the exact pose T_wc and the per-pixel class labels. Same URI => same images,
// bit for bit.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/intrinsics.h"
#include "core/result.h"
#include "io/frame_source.h"
#include "synth/camera_model.h"
#include "synth/depth_noise.h"
#include "synth/room_builder.h"
#include "synth/scene.h"
#include "synth/trajectory.h"

namespace ef {

// Opens the synthetic source described by `uri` (its scheme is not checked). Unknown query keys,
// bad values and unknown rooms are errors naming them.
Result<std::unique_ptr<FrameSource>> open_synthetic(const SourceUri& uri);

// The built-in room names, the default first (for help text).
const std::vector<std::string>& synthetic_room_names();

// The Kinect-like default camera: 640x480, fx = fy = 525, cx = 319.5, cy = 239.5.
Intrinsics synthetic_default_intrinsics();

namespace synth {

enum class CameraKind {
  kIdeal,   // the renderer's colour image (Lambertian, sharp), plus DepthNoiseOptions::color_sigma
  kKinect,  // through ColorCamera (camera_model.h); DepthNoiseOptions::color_sigma is not applied
};

struct SyntheticOptions {
  std::string room;               // "" = default room, a built-in name, or "random"
  uint32_t seed = 0;              // see the file comment
  TrajectoryKind trajectory = TrajectoryKind::kLoop;
  int frames = 300;               // frames in the sequence
  int width = 640, height = 480;  // pixels
  bool noise = true;              // Kinect-like sensor noise on
  DepthNoiseOptions noise_options;
  CameraKind camera = CameraKind::kIdeal;
  CameraModelOptions camera_options;  // used with CameraKind::kKinect
  RoomLayout layout = RoomLayout::kWalls;
  float depth_bias = 0.0f;        // fraction, -0.2..0.2: a radial depth error (apply_depth_bias)
};

// Parses the URI's path and query into options; errors name the offending key or value.
Result<SyntheticOptions> parse_synthetic_options(const SourceUri& uri);

// The synthetic source with direct access to its scene and trajectory (for tests and tools).
class SyntheticSource;
Result<std::unique_ptr<SyntheticSource>> open_synthetic_source(const SyntheticOptions& options, std::string uri_text);

class SyntheticSource final : public FrameSource {
 public:
  ~SyntheticSource() override;
  const SourceInfo& info() const override;
  Result<bool> next(Frame& out) override;

  // Renders frame `index` (0 <= index < frame_count) into `out` regardless of the stream position.
  Status render(int64_t index, Frame& out);

  const Scene& scene() const;
  const std::vector<SE3>& poses() const;
  const SyntheticOptions& options() const;

 private:
  friend Result<std::unique_ptr<SyntheticSource>> open_synthetic_source(const SyntheticOptions&, std::string);
  struct Impl;
  explicit SyntheticSource(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace synth
}  // namespace ef
