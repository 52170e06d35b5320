#include "platform/devices/camera_common.h"

#include <cmath>

#include "io/text_parse.h"
#include "platform/devices/cameras.h"

namespace ef::camera {

std::string source_name(const SourceUri& uri) { return uri.scheme + ":" + uri.path; }

Status query_int(const SourceUri& uri, const char* key, int64_t min, int64_t max, int64_t& out) {
  const auto it = uri.query.find(key);
  if (it == uri.query.end()) return Status();
  if (!text::parse_int(it->second, min, max, out))
    return error(ErrorCode::kInvalidArgument, "source '" + source_name(uri) + "': option " + key + "=" + it->second +
                                                  " is not an integer in " + std::to_string(min) + ".." +
                                                  std::to_string(max));
  return Status();
}

Status query_size(const SourceUri& uri, const char* key, int& width, int& height, bool& given) {
  given = false;
  const auto it = uri.query.find(key);
  if (it == uri.query.end()) return Status();
  const std::string_view v = it->second;
  const std::size_t x = v.find('x');
  int64_t w = 0, h = 0;
  if (x == std::string_view::npos || !text::parse_int(v.substr(0, x), 1, 16384, w) ||
      !text::parse_int(v.substr(x + 1), 1, 16384, h))
    return error(ErrorCode::kInvalidArgument, "source '" + source_name(uri) + "': option " + key + "=" + it->second +
                                                  " is not WxH with 1..16384 pixels each (e.g. " + key + "=640x480)");
  width = int(w);
  height = int(h);
  given = true;
  return Status();
}

namespace {
// The intrinsics keys fx, fy, cx, cy are checked as the source will apply them.
Status check_intrinsics_keys(const SourceUri& uri) {
  Intrinsics k{525.f, 525.f, 319.5f, 239.5f, 640, 480};
  return text::apply_intrinsics_overrides(uri, k);
}

bool ends_with(const std::string& s, const char* suffix) {
  const std::size_t n = std::char_traits<char>::length(suffix);
  return s.size() >= n && s.compare(s.size() - n, n, suffix) == 0;
}
}  // namespace

Result<OpenNi2Request> parse_openni2_request(const SourceUri& uri) {
  EF_RETURN_IF_ERROR(check_query_keys(uri, {"size", "fps", "timeout_ms", "registration", "fx", "fy", "cx", "cy"}));
  OpenNi2Request r;
  EF_RETURN_IF_ERROR(query_size(uri, "size", r.width, r.height, r.size_given));
  int64_t fps = r.fps, timeout_ms = r.timeout_ms, registration = r.registration ? 1 : 0;
  EF_RETURN_IF_ERROR(query_int(uri, "fps", 1, 1000, fps));
  EF_RETURN_IF_ERROR(query_int(uri, "timeout_ms", 1, 600000, timeout_ms));
  EF_RETURN_IF_ERROR(query_int(uri, "registration", 0, 1, registration));
  EF_RETURN_IF_ERROR(check_intrinsics_keys(uri));
  r.fps = int(fps);
  r.timeout_ms = int(timeout_ms);
  r.registration = registration != 0;
  r.recording = ends_with(uri.path, ".oni") || ends_with(uri.path, ".ONI");
  return r;
}

Result<V4l2Request> parse_v4l2_request(const SourceUri& uri) {
  EF_RETURN_IF_ERROR(check_query_keys(uri, {"format", "size", "fps", "timeout_ms", "depth_scale", "fx", "fy", "cx", "cy"}));
  const std::string name = source_name(uri);
  if (uri.path.empty()) return error(ErrorCode::kInvalidArgument, "v4l2: no device given (expected v4l2:/dev/videoN)");
  V4l2Request r;
  EF_RETURN_IF_ERROR(query_size(uri, "size", r.width, r.height, r.size_given));
  int64_t fps = r.fps, timeout_ms = r.timeout_ms;
  EF_RETURN_IF_ERROR(query_int(uri, "fps", 1, 1000, fps));
  EF_RETURN_IF_ERROR(query_int(uri, "timeout_ms", 1, 600000, timeout_ms));
  r.fps = int(fps);
  r.timeout_ms = int(timeout_ms);
  if (auto it = uri.query.find("format"); it != uri.query.end()) {
    if (it->second != "rgb" && it->second != "z16")
      return error(ErrorCode::kInvalidArgument, name + ": option format=" + it->second + " is not rgb or z16");
    r.depth_camera = it->second == "z16";
  }
  if (auto it = uri.query.find("depth_scale"); it != uri.query.end()) {
    double s = 0;
    if (!text::parse_double(it->second, s) || !(s > 0))
      return error(ErrorCode::kInvalidArgument, name + ": option depth_scale=" + it->second +
                                                    " is not a positive number of metres per unit");
    r.depth_scale = float(s);
  }
  EF_RETURN_IF_ERROR(check_intrinsics_keys(uri));
  return r;
}

Intrinsics intrinsics_from_fov(int width, int height, double hfov_rad, double vfov_rad) {
  Intrinsics k;
  k.width = width;
  k.height = height;
  k.cx = 0.5f * float(width - 1);
  k.cy = 0.5f * float(height - 1);
  const double kPi = 3.14159265358979323846;
  if (hfov_rad > 0 && hfov_rad < kPi && vfov_rad > 0 && vfov_rad < kPi) {
    k.fx = float(0.5 * width / std::tan(0.5 * hfov_rad));
    k.fy = float(0.5 * height / std::tan(0.5 * vfov_rad));
  } else {
    k.fx = k.fy = 525.0f * float(width) / 640.0f;
  }
  return k;
}

Error camera_lost(const std::string& name, const std::string& why) {
  return error(ErrorCode::kNotFound, name + ": " + kCameraLostText + ": " + why);
}

}  // namespace ef::camera

namespace ef {

Result<CameraProbe> probe_openni2_camera(const SourceUri& uri) {
  if (!openni2_built()) return open_openni2_camera(uri).take_error();  // the stub: "not built: ..."
  EF_ASSIGN_OR_RETURN(const camera::OpenNi2Request r, camera::parse_openni2_request(uri));
  return CameraProbe{r.width, r.height, r.size_given, !r.recording};
}

Result<CameraProbe> probe_v4l2_camera(const SourceUri& uri) {
  if (!v4l2_built()) return open_v4l2_camera(uri).take_error();
  EF_ASSIGN_OR_RETURN(const camera::V4l2Request r, camera::parse_v4l2_request(uri));
  return CameraProbe{r.width, r.height, r.size_given, true};
}

}  // namespace ef
