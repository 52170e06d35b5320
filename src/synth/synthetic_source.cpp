#include "synth/synthetic_source.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "synth/renderer.h"
#include "synth/rng.h"
#include "synth/room_builder.h"

namespace ef {

namespace {

constexpr double kFps = 30.0;
constexpr int kMaxSide = 4096;        // pixels: the largest image side accepted
constexpr int kMaxFrames = 10000000;  // frames: a sanity bound

Error bad_value(const std::string& key, const std::string& value, const std::string& expected) {
  return error(ErrorCode::kInvalidArgument,
               "synthetic: bad value '" + value + "' for query key '" + key + "' (expected " + expected + ")");
}

// A whole decimal unsigned integer in [lo, hi], nothing else.
bool parse_uint(const std::string& s, uint64_t lo, uint64_t hi, uint64_t& out) {
  if (s.empty() || s.size() > 19) return false;
  uint64_t v = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + static_cast<uint64_t>(c - '0');
  }
  if (v < lo || v > hi) return false;
  out = v;
  return true;
}

}  // namespace

Intrinsics synthetic_default_intrinsics() { return Intrinsics{525.0f, 525.0f, 319.5f, 239.5f, 640, 480}; }

const std::vector<std::string>& synthetic_room_names() { return synth::builtin_room_names(); }

namespace synth {

Result<SyntheticOptions> parse_synthetic_options(const SourceUri& uri) {
  EF_RETURN_IF_ERROR(check_query_keys(uri, {"seed", "trajectory", "frames", "size", "noise", "camera", "layout", "depth_bias"}));
  SyntheticOptions o;
  o.room = uri.path;
  if (!o.room.empty() && o.room != "random") {
    bool known = false;
    for (const std::string& n : builtin_room_names()) known = known || n == o.room;
    if (!known) {
      std::string list;
      for (const std::string& n : builtin_room_names()) list += n + ", ";
      return error(ErrorCode::kInvalidArgument, "synthetic: unknown room '" + o.room + "' (known: " + list + "random)");
    }
  }
  for (const auto& [key, value] : uri.query) {
    uint64_t v = 0;
    if (key == "seed") {
      if (!parse_uint(value, 0, std::numeric_limits<uint32_t>::max(), v)) return bad_value(key, value, "an integer 0..4294967295");
      o.seed = static_cast<uint32_t>(v);
    } else if (key == "trajectory") {
      if (value == "loop") o.trajectory = TrajectoryKind::kLoop;
      else if (value == "robot") o.trajectory = TrajectoryKind::kRobot;
      else if (value == "inspect") o.trajectory = TrajectoryKind::kInspect;
      else return bad_value(key, value, "loop, robot or inspect");
    } else if (key == "frames") {
      if (!parse_uint(value, 1, kMaxFrames, v)) return bad_value(key, value, "a positive integer");
      o.frames = static_cast<int>(v);
    } else if (key == "size") {
      const auto x = value.find('x');
      uint64_t w = 0, h = 0;
      if (x == std::string::npos || !parse_uint(value.substr(0, x), 8, kMaxSide, w) ||
          !parse_uint(value.substr(x + 1), 8, kMaxSide, h))
        return bad_value(key, value, "WxH, each 8..4096 pixels, e.g. 320x240");
      o.width = static_cast<int>(w);
      o.height = static_cast<int>(h);
    } else if (key == "noise") {
      if (value == "0") o.noise = false;
      else if (value == "1") o.noise = true;
      else return bad_value(key, value, "0 or 1");
    } else if (key == "camera") {
      if (value == "ideal") o.camera = CameraKind::kIdeal;
      else if (value == "kinect") o.camera = CameraKind::kKinect;
      else return bad_value(key, value, "ideal or kinect");
    } else if (key == "depth_bias") {
      char* end = nullptr;
      const double b = std::strtod(value.c_str(), &end);
      if (value.empty() || end != value.c_str() + value.size() || !(b >= -0.2 && b <= 0.2))
        return bad_value(key, value, "a fraction -0.2..0.2, e.g. 0.02");
      o.depth_bias = static_cast<float>(b);
    } else if (key == "layout") {
      if (value == "walls") o.layout = RoomLayout::kWalls;
      else if (value == "island") o.layout = RoomLayout::kIsland;
      else return bad_value(key, value, "walls or island");
    }
  }
  return o;
}

struct SyntheticSource::Impl {
  SyntheticOptions options;
  SourceInfo info;
  Scene scene;
  std::vector<SE3> poses;
  std::unique_ptr<Renderer> renderer;
  std::unique_ptr<KinectNoise> noise;
  std::unique_ptr<ColorCamera> camera;  // null with CameraKind::kIdeal
  int64_t next_index = 0;
};

SyntheticSource::SyntheticSource(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SyntheticSource::~SyntheticSource() = default;
const SourceInfo& SyntheticSource::info() const { return impl_->info; }
const Scene& SyntheticSource::scene() const { return impl_->scene; }
const std::vector<SE3>& SyntheticSource::poses() const { return impl_->poses; }
const SyntheticOptions& SyntheticSource::options() const { return impl_->options; }

Result<std::unique_ptr<SyntheticSource>> open_synthetic_source(const SyntheticOptions& options, std::string uri_text) {
  auto impl = std::make_unique<SyntheticSource::Impl>();
  impl->options = options;
  EF_ASSIGN_OR_RETURN(impl->scene, build_room(options.room, options.seed, options.layout, options.trajectory));
  TrajectoryOptions t;
  t.kind = options.trajectory;
  t.frames = options.frames;
  t.fps = kFps;
  t.seed = options.seed;
  EF_ASSIGN_OR_RETURN(impl->poses, make_trajectory(impl->scene, t));
  const Intrinsics K = synthetic_default_intrinsics().scaled_to(options.width, options.height);
  impl->info.uri = std::move(uri_text);
  impl->info.intrinsics = K;
  impl->info.intrinsics_from = "the synthetic camera";
  impl->info.frame_count = options.frames;
  impl->info.nominal_fps = kFps;
  impl->info.has_pose = true;
  impl->info.has_labels = true;
  impl->info.has_color = true;
  impl->info.live = false;
  impl->renderer = std::make_unique<Renderer>(impl->scene, K);
  DepthNoiseOptions noise_options = options.noise_options;
  if (options.camera == CameraKind::kKinect) {
    impl->camera = std::make_unique<ColorCamera>(options.camera_options, K.width, K.height, kFps);
    noise_options.color_sigma = 0.0f;  // the camera model has its own colour noise
  }
  impl->noise = std::make_unique<KinectNoise>(noise_options, K.width, K.height);
  return std::unique_ptr<SyntheticSource>(new SyntheticSource(std::move(impl)));
}

Status SyntheticSource::render(int64_t index, Frame& out) {
  Impl& m = *impl_;
  if (index < 0 || index >= static_cast<int64_t>(m.poses.size()))
    return error(ErrorCode::kOutOfRange, "synthetic: frame " + std::to_string(index) + " outside 0.." +
                                             std::to_string(m.poses.size() - 1));
  const Intrinsics& K = m.info.intrinsics;
  out.allocate(K.width, K.height, true);
  // One independent stream per (seed, frame): frames can be rendered in any order.
  const uint64_t frame_seed = (static_cast<uint64_t>(synth::hash32(m.options.seed, 0x6e6f6973u)) << 32) |
                              static_cast<uint64_t>(index);
  if (m.camera) {
    m.camera->capture(*m.renderer, m.poses, index, m.options.noise, frame_seed, out.color.view(), out.depth.view(),
                      out.labels.view());
  } else {
    m.renderer->render(m.poses[index], out.color.view(), out.depth.view(), out.labels.view());
  }
  if (m.options.noise) {
    m.noise->apply(frame_seed, out.depth.view(), m.renderer->incidence(), out.color.view());
  }
  if (m.options.depth_bias != 0.0f) apply_depth_bias(m.options.depth_bias, K, out.depth.view());
  out.timestamp = static_cast<double>(index) / kFps;
  out.index = index;
  out.T_wc = m.poses[index];
  out.has_pose = true;
  out.has_labels = true;
  char name[32];
  std::snprintf(name, sizeof(name), "%06lld", static_cast<long long>(index));
  out.name.assign(name);
  return Status::success();
}

Result<bool> SyntheticSource::next(Frame& out) {
  if (impl_->next_index >= static_cast<int64_t>(impl_->poses.size())) return false;
  EF_RETURN_IF_ERROR(render(impl_->next_index, out));
  ++impl_->next_index;
  return true;
}

}  // namespace synth

Result<std::unique_ptr<FrameSource>> open_synthetic(const SourceUri& uri) {
  EF_ASSIGN_OR_RETURN(synth::SyntheticOptions options, synth::parse_synthetic_options(uri));
  std::string text = uri.scheme + ":" + uri.path;
  char sep = '?';
  for (const auto& [k, v] : uri.query) {
    text += sep + k + "=" + v;
    sep = '&';
  }
  EF_ASSIGN_OR_RETURN(auto source, synth::open_synthetic_source(options, std::move(text)));
  return std::unique_ptr<FrameSource>(std::move(source));
}

}  // namespace ef
