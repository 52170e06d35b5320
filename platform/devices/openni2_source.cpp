// OpenNI2 cameras and .oni recordings (cameras.h has the URI and the behaviour). Built only when
// CMake finds libopenni2-dev (EF_HAVE_OPENNI2).
#include <OpenNI.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <thread>
#include <vector>

#include "io/text_parse.h"
#include "kernels/depth_convert.h"
#include "platform/devices/camera_common.h"
#include "platform/devices/cameras.h"

namespace ef {

namespace {

constexpr int kStopGraceMs = 250;  // after stopping the streams, before destroying them (close())

// OpenNI's last error text on one line ("no detail" when it has none).
std::string oni_error() {
  std::string s = openni::OpenNI::getExtendedError();
  for (char& c : s)
    if (c == '\n' || c == '\t' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  while (!s.empty() && s.front() == ' ') s.erase(s.begin());
  return s.empty() ? "no detail from OpenNI2" : s;
}

bool is_depth_format(openni::PixelFormat f) {
  return f == openni::PIXEL_FORMAT_DEPTH_1_MM || f == openni::PIXEL_FORMAT_DEPTH_100_UM;
}

struct Size {
  int width, height;
  bool operator==(const Size& o) const { return width == o.width && height == o.height; }
};

std::vector<openni::VideoMode> modes_of(const openni::SensorInfo* sensor, bool depth) {
  std::vector<openni::VideoMode> out;
  if (sensor == nullptr) return out;
  const auto& modes = sensor->getSupportedVideoModes();
  for (int i = 0; i < modes.getSize(); ++i) {
    const openni::PixelFormat f = modes[i].getPixelFormat();
    if (depth ? is_depth_format(f) : f == openni::PIXEL_FORMAT_RGB888) out.push_back(modes[i]);
  }
  return out;
}

bool has_size(const std::vector<openni::VideoMode>& modes, Size s) {
  return std::any_of(modes.begin(), modes.end(), [&](const openni::VideoMode& m) {
    return m.getResolutionX() == s.width && m.getResolutionY() == s.height;
  });
}

std::string sizes_text(const std::vector<Size>& sizes) {
  std::string out;
  for (const Size& s : sizes) out += (out.empty() ? "" : ", ") + std::to_string(s.width) + "x" + std::to_string(s.height);
  return out.empty() ? "none" : out;
}

// The mode of `size` with fps `want_fps` (0: 30 if there, else the fastest); 1 mm depth preferred.
const openni::VideoMode* pick_mode(const std::vector<openni::VideoMode>& modes, Size size, int want_fps) {
  const openni::VideoMode* best = nullptr;
  const auto score = [&](const openni::VideoMode& m) {
    const int fps = m.getFps();
    const int fps_score = want_fps > 0 ? (fps == want_fps ? 1000 : -1) : (fps == 30 ? 1000 : fps);
    return fps_score * 2 + (m.getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_100_UM ? 0 : 1);
  };
  for (const auto& m : modes) {
    if (m.getResolutionX() != size.width || m.getResolutionY() != size.height) continue;
    if (want_fps > 0 && m.getFps() != want_fps) continue;
    if (best == nullptr || score(m) > score(*best)) best = &m;
  }
  return best;
}

// OpenNI2 is initialised once per process, at the first camera, and shut down only when the process
// exits. Shutting it down unloads the drivers (dlclose), and a driver's frame thread that has not
// left yet then runs unmapped code: OpenNI2's own Dummy driver stops its threads by a flag without
// joining them. Keeping OpenNI2 up also keeps its device hot-plug events flowing between runs.
Status initialize_openni(const std::string& name) {
  static const openni::Status status = openni::OpenNI::initialize();
  static const std::string detail = status == openni::STATUS_OK ? std::string() : oni_error();
  if (status != openni::STATUS_OK)
    return error(ErrorCode::kIoError, name + ": OpenNI2 does not initialise: " + detail);
  return Status();
}

class OpenNi2Camera final : public CameraSource, private openni::OpenNI::DeviceDisconnectedListener {
 public:
  OpenNi2Camera() = default;
  OpenNi2Camera(const OpenNi2Camera&) = delete;
  OpenNi2Camera& operator=(const OpenNi2Camera&) = delete;
  ~OpenNi2Camera() override { close(); }

  Status open(const SourceUri& uri);
  const SourceInfo& info() const override { return info_; }
  Result<bool> next(Frame& out) override;
  void notify_disconnected() override { lost_.store(true, std::memory_order_release); }

 private:
  // OpenNI calls this on its own thread for any device that goes away.
  void onDeviceDisconnected(const openni::DeviceInfo* device) override {
    if (device != nullptr && device_uri_ == device->getUri()) notify_disconnected();
  }
  void close();
  Status read_color(double depth_time_s);
  Error fail(ErrorCode code, const std::string& what) const {
    return error(code, name_ + ", frame " + std::to_string(delivered_) + ": " + what);
  }

  SourceInfo info_;
  std::string name_;        // "openni2:Dummy"
  std::string device_uri_;  // as OpenNI names the opened device
  int timeout_ms_ = 2000;
  bool listening_ = false, started_ = false, is_file_ = false;
  openni::Device device_;
  openni::VideoStream depth_, color_;
  openni::VideoFrameRef depth_frame_, color_frame_;
  float metres_per_unit_ = 0.001f;  // of the depth stream's pixel format
  int64_t delivered_ = 0;
  int64_t color_count_ = 0, color_read_ = 0;  // of a recording
  std::atomic<bool> lost_{false};
};

Status OpenNi2Camera::open(const SourceUri& uri) {
  EF_ASSIGN_OR_RETURN(const camera::OpenNi2Request request, camera::parse_openni2_request(uri));
  name_ = camera::source_name(uri);
  const Size want{request.width, request.height};
  const bool size_given = request.size_given;
  const int64_t fps = request.fps;
  const int64_t registration = request.registration ? 1 : 0;
  timeout_ms_ = request.timeout_ms;

  EF_RETURN_IF_ERROR(initialize_openni(name_));
  const char* device_arg = uri.path.empty() ? openni::ANY_DEVICE : uri.path.c_str();
  if (device_.open(device_arg) != openni::STATUS_OK)
    return error(ErrorCode::kNotFound,
                 name_ + ": " + (uri.path.empty() ? std::string("no OpenNI2 device found")
                                                  : "no OpenNI2 device or .oni recording '" + uri.path + "'") +
                     " (" + oni_error() + ")");
  device_uri_ = device_.getDeviceInfo().getUri();
  is_file_ = device_.isFile();

  const auto depth_modes = modes_of(device_.getSensorInfo(openni::SENSOR_DEPTH), true);
  const auto color_modes = modes_of(device_.getSensorInfo(openni::SENSOR_COLOR), false);
  if (depth_modes.empty())
    return error(ErrorCode::kUnsupported, name_ + ": the device has no depth stream in 1 mm or 100 um units");
  const bool with_color = !color_modes.empty();
  // Sizes both streams have (depth alone when there is no colour), largest first.
  std::vector<Size> sizes;
  for (const auto& m : depth_modes) {
    const Size s{m.getResolutionX(), m.getResolutionY()};
    if ((!with_color || has_size(color_modes, s)) && std::find(sizes.begin(), sizes.end(), s) == sizes.end())
      sizes.push_back(s);
  }
  std::sort(sizes.begin(), sizes.end(),
            [](Size a, Size b) { return int64_t(a.width) * a.height > int64_t(b.width) * b.height; });
  if (sizes.empty())
    return error(ErrorCode::kUnsupported, name_ + ": the depth and colour streams share no resolution");
  Size size = sizes.front();
  if (size_given || std::find(sizes.begin(), sizes.end(), want) != sizes.end()) size = want;
  if (std::find(sizes.begin(), sizes.end(), size) == sizes.end())
    return error(ErrorCode::kUnsupported, name_ + ": no " + std::to_string(want.width) + "x" +
                                              std::to_string(want.height) + " mode (the device has " +
                                              sizes_text(sizes) + ")");
  const openni::VideoMode* depth_mode = pick_mode(depth_modes, size, int(fps));
  const openni::VideoMode* color_mode = with_color ? pick_mode(color_modes, size, depth_mode ? depth_mode->getFps() : int(fps)) : nullptr;
  if (depth_mode == nullptr || (with_color && color_mode == nullptr))
    return error(ErrorCode::kUnsupported, name_ + ": no " + std::to_string(size.width) + "x" +
                                              std::to_string(size.height) + " mode at " + std::to_string(fps) +
                                              " fps for both streams");

  // A mode is set only when it differs from the stream's current one: drivers with one fixed mode
  // (the Dummy device, recordings) refuse the property altogether.
  const auto set_mode = [&](openni::VideoStream& stream, const openni::VideoMode& mode) {
    const openni::VideoMode now = stream.getVideoMode();
    if (now.getResolutionX() == mode.getResolutionX() && now.getResolutionY() == mode.getResolutionY() &&
        now.getFps() == mode.getFps() && now.getPixelFormat() == mode.getPixelFormat())
      return true;
    return is_file_ || stream.setVideoMode(mode) == openni::STATUS_OK;
  };
  if (depth_.create(device_, openni::SENSOR_DEPTH) != openni::STATUS_OK || !set_mode(depth_, *depth_mode))
    return error(ErrorCode::kIoError, name_ + ": cannot set up the depth stream: " + oni_error());
  if (with_color && (color_.create(device_, openni::SENSOR_COLOR) != openni::STATUS_OK || !set_mode(color_, *color_mode)))
    return error(ErrorCode::kIoError, name_ + ": cannot set up the colour stream: " + oni_error());
  // Unmirrored images: the camera frame is x right, y down as everywhere in EdgeFusion. Drivers
  // without the property (the Dummy, files) return an error that does not matter.
  (void)depth_.setMirroringEnabled(false);
  if (with_color) (void)color_.setMirroringEnabled(false);
  bool registered = false;
  if (with_color && registration != 0 && !is_file_ &&
      device_.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR))
    registered = device_.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) == openni::STATUS_OK;
  if (with_color) (void)device_.setDepthColorSyncEnabled(true);

  info_.uri = uri.scheme + ":" + uri.path;
  info_.live = !is_file_;
  info_.has_color = with_color;
  info_.nominal_fps = depth_mode->getFps() > 0 ? depth_mode->getFps() : 30;
  if (is_file_) {
    openni::PlaybackControl* playback = device_.getPlaybackControl();
    if (playback == nullptr) return error(ErrorCode::kInternal, name_ + ": a recording without playback control");
    // Speed -1: the recording advances only when a frame is read, so no frame is skipped.
    (void)playback->setSpeed(-1.0f);
    (void)playback->setRepeatEnabled(false);
    info_.frame_count = playback->getNumberOfFrames(depth_);
    if (with_color) color_count_ = playback->getNumberOfFrames(color_);
  }
  metres_per_unit_ = depth_mode->getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_100_UM ? 0.0001f : 0.001f;

  if (openni::OpenNI::addDeviceDisconnectedListener(this) == openni::STATUS_OK) listening_ = true;
  if (depth_.start() != openni::STATUS_OK)
    return error(ErrorCode::kIoError, name_ + ": cannot start the depth stream: " + oni_error());
  started_ = true;
  if (with_color && color_.start() != openni::STATUS_OK)
    return error(ErrorCode::kIoError, name_ + ": cannot start the colour stream: " + oni_error());

  // The mode the stream really runs (a recording has its own).
  const openni::VideoMode running = depth_.getVideoMode();
  size = Size{running.getResolutionX(), running.getResolutionY()};
  const openni::VideoStream& geometry = registered ? color_ : depth_;
  info_.intrinsics = camera::intrinsics_from_fov(size.width, size.height, geometry.getHorizontalFieldOfView(),
                                                 geometry.getVerticalFieldOfView());
  EF_RETURN_IF_ERROR(text::apply_intrinsics_overrides(uri, info_.intrinsics));

  // A camera that opens but sends nothing fails here rather than at the first frame. The first
  // frame of each stream is read and dropped: a stream's first frame may not be settled (OpenNI2's
  // Dummy device, reopened in one process, sends its first depth frame now and then with the pixel
  // format and stride of a colour frame).
  if (!is_file_) {
    openni::VideoStream* streams[] = {&depth_};
    int ready = -1;
    if (openni::OpenNI::waitForAnyStream(streams, 1, &ready, timeout_ms_) != openni::STATUS_OK ||
        depth_.readFrame(&depth_frame_) != openni::STATUS_OK)
      return error(ErrorCode::kIoError, name_ + ": opened, but no depth frame came within " +
                                            std::to_string(timeout_ms_) + " ms (" + oni_error() + ")");
    streams[0] = &color_;
    if (with_color && (openni::OpenNI::waitForAnyStream(streams, 1, &ready, timeout_ms_) != openni::STATUS_OK ||
                       color_.readFrame(&color_frame_) != openni::STATUS_OK))
      return error(ErrorCode::kIoError, name_ + ": opened, but no colour frame came within " +
                                            std::to_string(timeout_ms_) + " ms (" + oni_error() + ")");
  }
  return Status();
}

void OpenNi2Camera::close() {
  if (listening_) openni::OpenNI::removeDeviceDisconnectedListener(this);
  listening_ = false;
  depth_frame_.release();
  color_frame_.release();
  if (started_) {
    depth_.stop();
    color_.stop();
    // Some drivers' frame threads (OpenNI2's own Dummy device) notice stop() only after their
    // current frame and up to two 33 ms sleeps, and are not joined: let them leave before the stream
    // objects they use are destroyed.
    std::this_thread::sleep_for(std::chrono::milliseconds(kStopGraceMs));
    started_ = false;
  }
  depth_.destroy();
  color_.destroy();
  device_.close();
}

Status OpenNi2Camera::read_color(double depth_time_s) {
  openni::VideoStream* streams[] = {&color_};
  int ready = -1;
  if (is_file_) {
    // Frame by frame: the recording's n-th colour frame goes with its n-th depth frame; a recording
    // with fewer colour frames repeats its last one.
    if (color_read_ >= color_count_) {
      if (color_frame_.isValid()) return Status();
      return fail(ErrorCode::kCorruptData, "the recording has no colour frame");
    }
    if (openni::OpenNI::waitForAnyStream(streams, 1, &ready, timeout_ms_) != openni::STATUS_OK)
      return fail(ErrorCode::kIoError, "the recording delivered no colour frame within " +
                                           std::to_string(timeout_ms_) + " ms");
    if (color_.readFrame(&color_frame_) != openni::STATUS_OK)
      return fail(ErrorCode::kIoError, "cannot read the colour frame: " + oni_error());
    ++color_read_;
    return Status();
  }
  if (openni::OpenNI::waitForAnyStream(streams, 1, &ready, timeout_ms_) != openni::STATUS_OK)
    return camera::camera_lost(name_, "no colour frame within " + std::to_string(timeout_ms_) + " ms");
  if (color_.readFrame(&color_frame_) != openni::STATUS_OK)
    return fail(ErrorCode::kIoError, "cannot read the colour frame: " + oni_error());
  // A live colour stream that runs ahead of depth would lag more every frame: take the newest colour
  // frame that is ready, as long as it is not more than half a frame period older than the depth.
  const double half_period_s = 0.5 / info_.nominal_fps;
  while (!is_file_ && double(color_frame_.getTimestamp()) * 1e-6 < depth_time_s - half_period_s &&
         openni::OpenNI::waitForAnyStream(streams, 1, &ready, 0) == openni::STATUS_OK) {
    if (color_.readFrame(&color_frame_) != openni::STATUS_OK)
      return fail(ErrorCode::kIoError, "cannot read the colour frame: " + oni_error());
  }
  return Status();
}

Result<bool> OpenNi2Camera::next(Frame& out) {
  if (lost_.load(std::memory_order_acquire)) return camera::camera_lost(name_, "the device was disconnected");
  if (is_file_ && info_.frame_count >= 0 && delivered_ >= info_.frame_count) return false;
  // A recording ends at its frame count (checked above); a wait that times out before is an error.
  openni::VideoStream* streams[] = {&depth_};
  int ready = -1;
  if (openni::OpenNI::waitForAnyStream(streams, 1, &ready, timeout_ms_) != openni::STATUS_OK) {
    if (lost_.load(std::memory_order_acquire)) return camera::camera_lost(name_, "the device was disconnected");
    if (is_file_)
      return fail(ErrorCode::kIoError, "the recording delivered no depth frame within " +
                                           std::to_string(timeout_ms_) + " ms (it has " +
                                           std::to_string(info_.frame_count) + ")");
    return camera::camera_lost(name_, "no depth frame within " + std::to_string(timeout_ms_) +
                                          " ms (unplugged or powered off?)");
  }
  if (lost_.load(std::memory_order_acquire)) return camera::camera_lost(name_, "the device was disconnected");
  if (depth_.readFrame(&depth_frame_) != openni::STATUS_OK)
    return fail(ErrorCode::kIoError, "cannot read the depth frame: " + oni_error());

  const int w = info_.intrinsics.width, h = info_.intrinsics.height;
  if (depth_frame_.getWidth() != w || depth_frame_.getHeight() != h ||
      !is_depth_format(depth_frame_.getVideoMode().getPixelFormat()) ||
      depth_frame_.getStrideInBytes() < w * int(sizeof(uint16_t)) ||
      depth_frame_.getDataSize() < depth_frame_.getStrideInBytes() * h)
    return fail(ErrorCode::kCorruptData,
                "depth frame of " + std::to_string(depth_frame_.getWidth()) + "x" +
                    std::to_string(depth_frame_.getHeight()) + " in pixel format " +
                    std::to_string(int(depth_frame_.getVideoMode().getPixelFormat())) + ", " +
                    std::to_string(depth_frame_.getStrideInBytes()) + " bytes per row, " +
                    std::to_string(depth_frame_.getDataSize()) + " bytes; expected " + std::to_string(w) + "x" +
                    std::to_string(h) + " 16-bit depth (formats 100, 101)");
  const float metres_per_unit =
      depth_frame_.getVideoMode().getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_100_UM ? 0.0001f : metres_per_unit_;
  out.depth.allocate(w, h);
  const auto* depth_bytes = static_cast<const unsigned char*>(depth_frame_.getData());
  for (int y = 0; y < h; ++y)
    kernels::depth_u16_to_metres(
        reinterpret_cast<const uint16_t*>(depth_bytes + std::size_t(y) * std::size_t(depth_frame_.getStrideInBytes())),
        out.depth.data() + std::size_t(y) * std::size_t(w), std::size_t(w), metres_per_unit, 65535);
  const double t = double(depth_frame_.getTimestamp()) * 1e-6;  // device clock, microseconds

  if (info_.has_color) {
    EF_RETURN_IF_ERROR(read_color(t));
    if (color_frame_.getWidth() != w || color_frame_.getHeight() != h ||
        color_frame_.getVideoMode().getPixelFormat() != openni::PIXEL_FORMAT_RGB888 ||
        color_frame_.getStrideInBytes() < w * 3 || color_frame_.getDataSize() < color_frame_.getStrideInBytes() * h)
      return fail(ErrorCode::kCorruptData, "colour frame of " + std::to_string(color_frame_.getWidth()) + "x" +
                                               std::to_string(color_frame_.getHeight()) + ", expected " +
                                               std::to_string(w) + "x" + std::to_string(h) + " RGB888");
    out.color.allocate(w, h);
    const auto* color_bytes = static_cast<const unsigned char*>(color_frame_.getData());
    for (int y = 0; y < h; ++y)
      std::memcpy(out.color.data() + std::size_t(y) * std::size_t(w),
                  color_bytes + std::size_t(y) * std::size_t(color_frame_.getStrideInBytes()), std::size_t(w) * 3);
  } else {
    out.color = Image<Rgb8>();
  }
  out.has_labels = false;
  out.has_pose = false;
  out.T_wc = SE3();
  out.timestamp = t;
  out.index = delivered_;
  char name[32];
  std::snprintf(name, sizeof(name), "%.6f", t);
  out.name.assign(name);
  ++delivered_;
  return true;
}

}  // namespace

Result<std::unique_ptr<CameraSource>> open_openni2_camera(const SourceUri& uri) {
  auto camera = std::make_unique<OpenNi2Camera>();
  EF_RETURN_IF_ERROR(camera->open(uri));
  return std::unique_ptr<CameraSource>(std::move(camera));
}

bool openni2_built() { return true; }

}  // namespace ef
