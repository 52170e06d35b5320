// The Foxglove message types our field logs use (https://github.com/foxglove/schemas, ROS 2
// flavour: foxglove_msgs/msg/*), as MCAP schemas with encoding "ros2msg" and CDR messages
// (io/cdr.h), so that Foxglove and ROS 2's tools (rosbag2's MCAP storage) open the logs.
//
// A ros2msg schema is the type's definition followed, for each type it nests, by a line of 80
// '=' characters, "MSG: pkg/Type" and that type's definition (rosbag2's layout).
//
// Encoders write one whole message into `out` (replaced; allocation-free once its capacity is
// reached). Decoders read the fields our replay needs, pointing into the message's bytes; an error
// names the message, the field and the log offset given as `where`.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "core/result.h"
#include "core/se3.h"

namespace ef::foxglove {

struct SchemaText {
  const char* name;        // "foxglove_msgs/msg/CompressedImage"
  std::string definition;  // ros2msg text with its nested types
};
const SchemaText& compressed_image_schema();
const SchemaText& raw_image_schema();
const SchemaText& camera_calibration_schema();
const SchemaText& pose_in_frame_schema();
const SchemaText& frame_transform_schema();
const SchemaText& log_schema();
const SchemaText& point_cloud_schema();

// Seconds (a frame's timestamp) <-> builtin_interfaces/Time and MCAP nanoseconds. Negative or
// non-finite seconds are clamped to 0.
uint64_t to_nanoseconds(double seconds);

// CompressedImage: format "png", "jpeg" or "webp".
void encode_compressed_image(uint64_t stamp_ns, std::string_view frame_id, const void* data, std::size_t bytes,
                             std::string_view format, std::string& out);
// RawImage: encoding "16UC1", "rgb8", "mono8", ...; rows of `step` bytes, tightly packed.
// `data` may be null: the caller then fills raw_image_data(out) (height * step bytes) itself.
void encode_raw_image(uint64_t stamp_ns, std::string_view frame_id, uint32_t width, uint32_t height,
                      std::string_view encoding, uint32_t step, const void* data, std::string& out);
// Where encode_raw_image(..., nullptr, out) left room for the pixels.
char* raw_image_data(std::string& out, uint32_t height, uint32_t step);
// CameraCalibration of a pinhole camera without distortion (d empty, r identity, p = [K | 0]).
void encode_camera_calibration(uint64_t stamp_ns, std::string_view frame_id, uint32_t width, uint32_t height,
                               double fx, double fy, double cx, double cy, std::string& out);
// PoseInFrame: T_wc as position and orientation in `frame_id` (the map frame, "world").
void encode_pose_in_frame(uint64_t stamp_ns, std::string_view frame_id, const SE3& T_wc, std::string& out);
// FrameTransform parent -> child (T_parent_child).
void encode_frame_transform(uint64_t stamp_ns, std::string_view parent, std::string_view child, const SE3& T,
                            std::string& out);
enum class LogLevel : uint8_t { kUnknown = 0, kDebug = 1, kInfo = 2, kWarning = 3, kError = 4, kFatal = 5 };
void encode_log(uint64_t stamp_ns, LogLevel level, std::string_view message, std::string_view name, std::string& out);

// PointCloud: a packed point cloud in `frame_id` (pose: identity). Writes the message up to and
// including the length of its data (`points * stride` bytes), which the caller appends (or streams:
// the map snapshots of io/mcap_log.h). Field types are foxglove_msgs/PackedElementField's numbers.
struct PackedField {
  const char* name;
  uint32_t offset;
  uint8_t type;  // 1 UINT8, 7 FLOAT32 (foxglove_msgs/PackedElementField)
};
void encode_point_cloud_head(uint64_t stamp_ns, std::string_view frame_id, uint32_t stride, const PackedField* fields,
                             std::size_t field_count, uint64_t points, std::string& out);

struct ImageMessage {
  uint64_t stamp_ns = 0;
  std::string_view frame_id;
  std::string_view format;    // CompressedImage's format, or RawImage's encoding
  uint32_t width = 0, height = 0, step = 0;  // RawImage only
  const uint8_t* data = nullptr;
  std::size_t bytes = 0;
};
Status decode_compressed_image(const uint8_t* msg, std::size_t size, ImageMessage& out, const std::string& where);
Status decode_raw_image(const uint8_t* msg, std::size_t size, ImageMessage& out, const std::string& where);
struct Calibration {
  uint64_t stamp_ns = 0;
  uint32_t width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};
Status decode_camera_calibration(const uint8_t* msg, std::size_t size, Calibration& out, const std::string& where);
struct PoseMessage {
  uint64_t stamp_ns = 0;
  SE3 T_wc;
};
Status decode_pose_in_frame(const uint8_t* msg, std::size_t size, PoseMessage& out, const std::string& where);

}  // namespace ef::foxglove
