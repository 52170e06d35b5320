// Video4Linux2 cameras with memory-mapped buffers through libv4l2 (cameras.h has the URI and the
// behaviour). Built only when CMake finds libv4l-dev (EF_HAVE_V4L2). libv4l2's calls are the
// kernel's ioctl/mmap with format conversion added: asking for RGB24 works with YUYV and MJPEG
// cameras; Z16 depth passes through unconverted.
#include <fcntl.h>
#include <libv4l2.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <vector>

#include "io/text_parse.h"
#include "kernels/depth_convert.h"
#include "platform/devices/camera_common.h"
#include "platform/devices/cameras.h"

namespace ef {

namespace {

constexpr unsigned kBufferCount = 4;  // driver-side queue: enough to never stall a 30 fps camera

std::string fourcc_text(uint32_t f) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const char c = char((f >> (8 * i)) & 0xff);
    s += (c >= 32 && c < 127) ? c : '?';
  }
  return s;
}

// ioctl that retries when a signal interrupts it.
int xioctl(int fd, unsigned long request, void* arg) {
  int rc;
  do {
    rc = v4l2_ioctl(fd, request, arg);
  } while (rc == -1 && errno == EINTR);
  return rc;
}

// errno values with which the kernel says the device is gone (uvcvideo: ENODEV after unplug).
bool device_gone(int err) { return err == ENODEV || err == ENXIO || err == ESHUTDOWN; }

class V4l2Camera final : public CameraSource {
 public:
  V4l2Camera() = default;
  V4l2Camera(const V4l2Camera&) = delete;
  V4l2Camera& operator=(const V4l2Camera&) = delete;
  ~V4l2Camera() override { close(); }

  Status open(const SourceUri& uri);
  const SourceInfo& info() const override { return info_; }
  Result<bool> next(Frame& out) override;
  void notify_disconnected() override { lost_.store(true, std::memory_order_release); }

 private:
  struct Buffer {
    void* start = MAP_FAILED;
    std::size_t length = 0;
  };
  void close();
  Error sys_error(const std::string& what, int err) const {
    if (device_gone(err)) return camera::camera_lost(name_, what + ": " + std::strerror(err));
    return error(ErrorCode::kIoError, name_ + ", frame " + std::to_string(delivered_) + ": " + what + ": " +
                                          std::strerror(err));
  }
  Status fill_frame(const v4l2_buffer& buf, Frame& out);

  SourceInfo info_;
  std::string name_;
  int fd_ = -1;
  bool streaming_ = false;
  bool depth_camera_ = false;       // format=z16
  float depth_scale_ = 0.001f;      // metres per Z16 unit
  uint32_t bytes_per_line_ = 0;
  int timeout_ms_ = 2000;
  std::vector<Buffer> buffers_;
  int64_t delivered_ = 0;
  std::atomic<bool> lost_{false};
};

Status V4l2Camera::open(const SourceUri& uri) {
  EF_ASSIGN_OR_RETURN(const camera::V4l2Request request, camera::parse_v4l2_request(uri));
  name_ = camera::source_name(uri);
  int width = request.width, height = request.height;
  const int64_t fps = request.fps;
  timeout_ms_ = request.timeout_ms;
  depth_camera_ = request.depth_camera;
  depth_scale_ = request.depth_scale;

  struct stat st {};
  if (::stat(uri.path.c_str(), &st) != 0) {
    const int err = errno;
    return error(err == ENOENT ? ErrorCode::kNotFound : ErrorCode::kIoError,
                 name_ + ": no video device '" + uri.path + "' (" + std::strerror(err) + ")");
  }
  if (!S_ISCHR(st.st_mode))
    return error(ErrorCode::kInvalidArgument, name_ + ": '" + uri.path + "' is not a device (expected /dev/videoN)");
  fd_ = v4l2_open(uri.path.c_str(), O_RDWR | O_NONBLOCK);
  if (fd_ < 0) {
    const int err = errno;
    return error(err == ENOENT || err == ENODEV ? ErrorCode::kNotFound : ErrorCode::kIoError,
                 name_ + ": cannot open '" + uri.path + "': " + std::strerror(err));
  }
  v4l2_capability cap{};
  if (xioctl(fd_, VIDIOC_QUERYCAP, &cap) != 0)
    return error(ErrorCode::kUnsupported, name_ + ": '" + uri.path + "' is not a V4L2 device (VIDIOC_QUERYCAP: " +
                                              std::strerror(errno) + ")");
  const uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE) || !(caps & V4L2_CAP_STREAMING))
    return error(ErrorCode::kUnsupported, name_ + ": '" + reinterpret_cast<const char*>(cap.card) +
                                              "' is not a streaming video capture device (a metadata or output node?)");

  const uint32_t want_format = depth_camera_ ? V4L2_PIX_FMT_Z16 : V4L2_PIX_FMT_RGB24;
  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  fmt.fmt.pix.width = uint32_t(width);
  fmt.fmt.pix.height = uint32_t(height);
  fmt.fmt.pix.pixelformat = want_format;
  fmt.fmt.pix.field = V4L2_FIELD_NONE;
  if (xioctl(fd_, VIDIOC_S_FMT, &fmt) != 0) return sys_error("VIDIOC_S_FMT", errno);
  if (fmt.fmt.pix.pixelformat != want_format)
    return error(ErrorCode::kUnsupported, name_ + ": the camera does not deliver " + fourcc_text(want_format) +
                                              " (it offered " + fourcc_text(fmt.fmt.pix.pixelformat) + ")" +
                                              (depth_camera_ ? "; is this the depth node of the camera?" : ""));
  width = int(fmt.fmt.pix.width);
  height = int(fmt.fmt.pix.height);
  const uint32_t pixel_bytes = depth_camera_ ? 2 : 3;
  bytes_per_line_ = std::max(fmt.fmt.pix.bytesperline, uint32_t(width) * pixel_bytes);

  v4l2_streamparm parm{};
  parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  parm.parm.capture.timeperframe.numerator = 1;
  parm.parm.capture.timeperframe.denominator = uint32_t(fps);
  double got_fps = double(fps);
  if (xioctl(fd_, VIDIOC_S_PARM, &parm) == 0 && parm.parm.capture.timeperframe.numerator > 0)
    got_fps = double(parm.parm.capture.timeperframe.denominator) / parm.parm.capture.timeperframe.numerator;

  v4l2_requestbuffers req{};
  req.count = kBufferCount;
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  if (xioctl(fd_, VIDIOC_REQBUFS, &req) != 0) return sys_error("VIDIOC_REQBUFS (memory-mapped buffers)", errno);
  if (req.count < 2)
    return error(ErrorCode::kResourceExhausted, name_ + ": the driver gave " + std::to_string(req.count) +
                                                    " buffers, at least 2 are needed");
  buffers_.resize(req.count);
  for (uint32_t i = 0; i < req.count; ++i) {
    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    buf.index = i;
    if (xioctl(fd_, VIDIOC_QUERYBUF, &buf) != 0) return sys_error("VIDIOC_QUERYBUF", errno);
    buffers_[i].length = buf.length;
    buffers_[i].start = v4l2_mmap(nullptr, buf.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, buf.m.offset);
    if (buffers_[i].start == MAP_FAILED) return sys_error("mmap of buffer " + std::to_string(i), errno);
    if (xioctl(fd_, VIDIOC_QBUF, &buf) != 0) return sys_error("VIDIOC_QBUF", errno);
  }
  v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd_, VIDIOC_STREAMON, &type) != 0) return sys_error("VIDIOC_STREAMON", errno);
  streaming_ = true;

  info_.uri = name_;
  info_.live = true;
  info_.frame_count = -1;
  info_.nominal_fps = got_fps;
  info_.has_color = !depth_camera_;
  info_.intrinsics = camera::intrinsics_from_fov(width, height, 0, 0);  // V4L2 has no optics: the default
  EF_RETURN_IF_ERROR(text::apply_intrinsics_overrides(uri, info_.intrinsics));
  return Status();
}

void V4l2Camera::close() {
  if (fd_ < 0) return;
  if (streaming_) {
    v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    (void)xioctl(fd_, VIDIOC_STREAMOFF, &type);
    streaming_ = false;
  }
  for (Buffer& b : buffers_)
    if (b.start != MAP_FAILED) v4l2_munmap(b.start, b.length);
  buffers_.clear();
  v4l2_close(fd_);
  fd_ = -1;
}

Result<bool> V4l2Camera::next(Frame& out) {
  for (;;) {
    if (lost_.load(std::memory_order_acquire)) return camera::camera_lost(name_, "the device was disconnected");
    pollfd pfd{fd_, POLLIN, 0};
    const int rc = ::poll(&pfd, 1, timeout_ms_);
    if (rc < 0) {
      if (errno == EINTR) continue;
      return sys_error("poll", errno);
    }
    if (rc == 0)
      return camera::camera_lost(name_, "no frame within " + std::to_string(timeout_ms_) +
                                            " ms (unplugged or powered off?)");
    if (pfd.revents & (POLLERR | POLLHUP | POLLNVAL))
      return camera::camera_lost(name_, "the device reported an error or hang-up while streaming");
    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    if (xioctl(fd_, VIDIOC_DQBUF, &buf) != 0) {
      if (errno == EAGAIN) continue;  // woken without a buffer ready
      return sys_error("VIDIOC_DQBUF", errno);
    }
    // The buffer goes back to the driver whatever happens to the frame.
    const Status filled = fill_frame(buf, out);
    if (xioctl(fd_, VIDIOC_QBUF, &buf) != 0) return sys_error("VIDIOC_QBUF", errno);
    if (!filled.ok()) return Status(filled).take_error();
    ++delivered_;
    return true;
  }
}

Status V4l2Camera::fill_frame(const v4l2_buffer& buf, Frame& out) {
  const int w = info_.intrinsics.width, h = info_.intrinsics.height;
  const std::size_t needed = std::size_t(bytes_per_line_) * std::size_t(h - 1) + std::size_t(w) * (depth_camera_ ? 2 : 3);
  const auto fail = [&](const std::string& what) {
    return error(ErrorCode::kCorruptData, name_ + ", frame " + std::to_string(delivered_) + ": " + what);
  };
  if (buf.index >= buffers_.size()) return fail("the driver returned buffer " + std::to_string(buf.index));
  if (buf.flags & V4L2_BUF_FLAG_ERROR) return fail("the driver flagged the frame as corrupted");
  if (buf.bytesused < needed || buffers_[buf.index].length < needed)
    return fail("frame of " + std::to_string(buf.bytesused) + " bytes, expected " + std::to_string(needed));
  const auto* bytes = static_cast<const unsigned char*>(buffers_[buf.index].start);
  out.depth.allocate(w, h);
  if (depth_camera_) {
    for (int y = 0; y < h; ++y)
      kernels::depth_u16_to_metres(reinterpret_cast<const uint16_t*>(bytes + std::size_t(y) * bytes_per_line_),
                                   out.depth.data() + std::size_t(y) * std::size_t(w), std::size_t(w), depth_scale_,
                                   65535);
    out.color = Image<Rgb8>();
  } else {
    out.color.allocate(w, h);
    for (int y = 0; y < h; ++y)
      std::memcpy(out.color.data() + std::size_t(y) * std::size_t(w), bytes + std::size_t(y) * bytes_per_line_,
                  std::size_t(w) * 3);
    out.depth.fill(0.0f);  // a colour camera measures no depth: every pixel invalid
  }
  out.has_labels = false;
  out.has_pose = false;
  out.T_wc = SE3();
  out.timestamp = double(buf.timestamp.tv_sec) + double(buf.timestamp.tv_usec) * 1e-6;
  out.index = delivered_;
  char name[32];
  std::snprintf(name, sizeof(name), "frame-%06lld", static_cast<long long>(delivered_));
  out.name.assign(name);
  return Status();
}

}  // namespace

Result<std::unique_ptr<CameraSource>> open_v4l2_camera(const SourceUri& uri) {
  auto camera = std::make_unique<V4l2Camera>();
  EF_RETURN_IF_ERROR(camera->open(uri));
  return std::unique_ptr<CameraSource>(std::move(camera));
}

bool v4l2_built() { return true; }

}  // namespace ef
