// Helpers shared by the camera sources: query options, default intrinsics, error texts.
#pragma once

#include <cstdint>
#include <string>

#include "core/intrinsics.h"
#include "core/result.h"
#include "io/frame_source.h"

namespace ef::camera {

// "openni2:Dummy" style name of a source for messages (scheme, path; no query).
std::string source_name(const SourceUri& uri);

// Reads query key `key` as an integer in [min, max] into `out` (left alone when the key is absent).
Status query_int(const SourceUri& uri, const char* key, int64_t min, int64_t max, int64_t& out);
// Reads `key` as WxH with each side in 1..16384 (left alone when absent). `given` says whether it was.
Status query_size(const SourceUri& uri, const char* key, int& width, int& height, bool& given);

// Pinhole intrinsics of a width x height image from horizontal / vertical fields of view (radians):
// f = (size / 2) / tan(fov / 2), principal point at the centre ((size - 1) / 2, pixel centres at
// integers). A field of view that is not in (0, pi) gives the PrimeSense default instead:
// fx = fy = 525 at 640x480, scaled to width (the TUM RGB-D default too).
Intrinsics intrinsics_from_fov(int width, int height, double hfov_rad, double vfov_rad);

// What an `openni2:` URI asks for (platform/devices/cameras.h documents the keys), read without
// touching a device: the one parser of its query, used by the camera's open() and by probe_camera().
struct OpenNi2Request {
  int width = 640, height = 480;  // the mode wanted; size_given false: 640x480 when the device has it
  bool size_given = false;
  int fps = 0;                     // 0 = 30 when the device has it, else the fastest
  int timeout_ms = 2000;
  bool registration = true;        // depth registered to colour where the device can
  bool recording = false;          // the path names a .oni file (not a live device)
};
Result<OpenNi2Request> parse_openni2_request(const SourceUri& uri);

// What a `v4l2:` URI asks for, likewise.
struct V4l2Request {
  int width = 640, height = 480;  // the size wanted (the driver may pick the nearest it has)
  bool size_given = false;
  int fps = 30;
  int timeout_ms = 2000;
  bool depth_camera = false;       // format=z16 (default rgb)
  float depth_scale = 0.001f;      // metres per unit of z16 depth
};
Result<V4l2Request> parse_v4l2_request(const SourceUri& uri);

// kNotFound "<name>: camera lost: <why>" (cameras.h: what the run loop stops on).
Error camera_lost(const std::string& name, const std::string& why);

}  // namespace ef::camera
