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
