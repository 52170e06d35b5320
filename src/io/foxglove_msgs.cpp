#include "io/foxglove_msgs.h"

#include <cmath>

#include "io/cdr.h"

namespace ef::foxglove {

namespace {

// Nested types, as rosbag2 lists them after a type's own definition.
const char* const kTime = "int32 sec\nuint32 nanosec\n";
const char* const kPose = "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n";
const char* const kPoint = "float64 x\nfloat64 y\nfloat64 z\n";
const char* const kVector3 = "float64 x\nfloat64 y\nfloat64 z\n";
const char* const kQuaternion = "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";

std::string nested(const char* type, const char* definition) {
  return std::string(80, '=') + "\nMSG: " + type + "\n" + definition;
}

std::string with_time(const std::string& own) { return own + nested("builtin_interfaces/Time", kTime); }

void time(cdr::Writer& w, uint64_t ns) {
  w.time(static_cast<int32_t>(ns / 1000000000u), static_cast<uint32_t>(ns % 1000000000u));
}

uint64_t read_time(cdr::Reader& r) {
  const int32_t sec = r.get<int32_t>("timestamp.sec");
  const uint32_t nsec = r.get<uint32_t>("timestamp.nanosec");
  return sec < 0 ? 0 : static_cast<uint64_t>(sec) * 1000000000u + nsec;
}

Status checked(const cdr::Reader& r, const char* type, const std::string& where) {
  if (r.ok()) return Status::success();
  return error(ErrorCode::kCorruptData,
               where + ": " + type + " message ends inside its field '" + r.what() + "' (not CDR of that type)");
}

void pose(cdr::Writer& w, const SE3& T) {
  const Eigen::Vector3d& t = T.translation();
  const Eigen::Quaterniond& q = T.rotation();
  for (double v : {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}) w.put<double>(v);
}

}  // namespace

const SchemaText& compressed_image_schema() {
  static const SchemaText s{"foxglove_msgs/msg/CompressedImage",
                            with_time("builtin_interfaces/Time timestamp\nstring frame_id\nuint8[] data\nstring format\n")};
  return s;
}

const SchemaText& raw_image_schema() {
  static const SchemaText s{"foxglove_msgs/msg/RawImage",
                            with_time("builtin_interfaces/Time timestamp\nstring frame_id\nuint32 width\nuint32 height\n"
                                      "string encoding\nuint32 step\nuint8[] data\n")};
  return s;
}

const SchemaText& camera_calibration_schema() {
  static const SchemaText s{"foxglove_msgs/msg/CameraCalibration",
                            with_time("builtin_interfaces/Time timestamp\nstring frame_id\nuint32 width\nuint32 height\n"
                                      "string distortion_model\nfloat64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\n")};
  return s;
}

const SchemaText& pose_in_frame_schema() {
  static const SchemaText s{"foxglove_msgs/msg/PoseInFrame",
                            with_time("builtin_interfaces/Time timestamp\nstring frame_id\ngeometry_msgs/Pose pose\n") +
                                nested("geometry_msgs/Pose", kPose) + nested("geometry_msgs/Point", kPoint) +
                                nested("geometry_msgs/Quaternion", kQuaternion)};
  return s;
}

const SchemaText& frame_transform_schema() {
  static const SchemaText s{
      "foxglove_msgs/msg/FrameTransform",
      with_time("builtin_interfaces/Time timestamp\nstring parent_frame_id\nstring child_frame_id\n"
                "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n") +
          nested("geometry_msgs/Vector3", kVector3) + nested("geometry_msgs/Quaternion", kQuaternion)};
  return s;
}

const SchemaText& log_schema() {
  static const SchemaText s{"foxglove_msgs/msg/Log",
                            with_time("builtin_interfaces/Time timestamp\nuint8 UNKNOWN=0\nuint8 DEBUG=1\nuint8 INFO=2\n"
                                      "uint8 WARNING=3\nuint8 ERROR=4\nuint8 FATAL=5\nuint8 level\nstring message\n"
                                      "string name\nstring file\nuint32 line\n")};
  return s;
}

const SchemaText& point_cloud_schema() {
  static const SchemaText s{
      "foxglove_msgs/msg/PointCloud",
      with_time("builtin_interfaces/Time timestamp\nstring frame_id\ngeometry_msgs/Pose pose\nuint32 point_stride\n"
                "foxglove_msgs/PackedElementField[] fields\nuint8[] data\n") +
          nested("geometry_msgs/Pose", kPose) + nested("geometry_msgs/Point", kPoint) +
          nested("geometry_msgs/Quaternion", kQuaternion) +
          nested("foxglove_msgs/PackedElementField",
                 "uint8 UNKNOWN=0\nuint8 UINT8=1\nuint8 INT8=2\nuint8 UINT16=3\nuint8 INT16=4\nuint8 UINT32=5\n"
                 "uint8 INT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 type\n")};
  return s;
}

void encode_point_cloud_head(uint64_t stamp_ns, std::string_view frame_id, uint32_t stride, const PackedField* fields,
                             std::size_t field_count, uint64_t points, std::string& out) {
  cdr::Writer w(out);
  time(w, stamp_ns);
  w.string(frame_id);
  pose(w, SE3());
  w.put<uint32_t>(stride);
  w.put<uint32_t>(static_cast<uint32_t>(field_count));
  for (std::size_t i = 0; i < field_count; ++i) {
    w.string(fields[i].name);
    w.put<uint32_t>(fields[i].offset);
    w.put<uint8_t>(fields[i].type);
  }
  w.put<uint32_t>(static_cast<uint32_t>(points * stride));  // data's length; the bytes follow
}

uint64_t to_nanoseconds(double seconds) {
  if (!(seconds > 0) || !std::isfinite(seconds)) return 0;
  return static_cast<uint64_t>(std::llround(seconds * 1e9));
}

void encode_compressed_image(uint64_t stamp_ns, std::string_view frame_id, const void* data, std::size_t bytes,
                             std::string_view format, std::string& out) {
  cdr::Writer w(out);
  time(w, stamp_ns);
  w.string(frame_id);
  w.bytes(data, bytes);
  w.string(format);
}

void encode_raw_image(uint64_t stamp_ns, std::string_view frame_id, uint32_t width, uint32_t height,
                      std::string_view encoding, uint32_t step, const void* data, std::string& out) {
  cdr::Writer w(out);
  time(w, stamp_ns);
  w.string(frame_id);
  w.put<uint32_t>(width);
  w.put<uint32_t>(height);
  w.string(encoding);
  w.put<uint32_t>(step);
  char* dst = w.bytes_in_place(static_cast<std::size_t>(height) * step);
  if (data != nullptr) std::memcpy(dst, data, static_cast<std::size_t>(height) * step);
}

char* raw_image_data(std::string& out, uint32_t height, uint32_t step) {
  return &out[out.size() - static_cast<std::size_t>(height) * step];
}

void encode_camera_calibration(uint64_t stamp_ns, std::string_view frame_id, uint32_t width, uint32_t height,
                               double fx, double fy, double cx, double cy, std::string& out) {
  cdr::Writer w(out);
  time(w, stamp_ns);
  w.string(frame_id);
  w.put<uint32_t>(width);
  w.put<uint32_t>(height);
  w.string("plumb_bob");
  w.put<uint32_t>(5);  // d: five zero coefficients (no distortion)
  for (int i = 0; i < 5; ++i) w.put<double>(0.0);
  for (double v : {fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0}) w.put<double>(v);                  // k
  for (double v : {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}) w.put<double>(v);               // r
  for (double v : {fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0}) w.put<double>(v);    // p
}

void encode_pose_in_frame(uint64_t stamp_ns, std::string_view frame_id, const SE3& T_wc, std::string& out) {
  cdr::Writer w(out);
  time(w, stamp_ns);
  w.string(frame_id);
  pose(w, T_wc);
}

void encode_frame_transform(uint64_t stamp_ns, std::string_view parent, std::string_view child, const SE3& T,
                            std::string& out) {
  cdr::Writer w(out);
  time(w, stamp_ns);
  w.string(parent);
  w.string(child);
  pose(w, T);
}

void encode_log(uint64_t stamp_ns, LogLevel level, std::string_view message, std::string_view name, std::string& out) {
  cdr::Writer w(out);
  time(w, stamp_ns);
  w.put<uint8_t>(static_cast<uint8_t>(level));
  w.string(message);
  w.string(name);
  w.string("");
  w.put<uint32_t>(0);
}

Status decode_compressed_image(const uint8_t* msg, std::size_t size, ImageMessage& out, const std::string& where) {
  cdr::Reader r(msg, size);
  out = ImageMessage{};
  out.stamp_ns = read_time(r);
  out.frame_id = r.string("frame_id");
  out.data = r.bytes("data", out.bytes);
  out.format = r.string("format");
  return checked(r, "CompressedImage", where);
}

Status decode_raw_image(const uint8_t* msg, std::size_t size, ImageMessage& out, const std::string& where) {
  cdr::Reader r(msg, size);
  out = ImageMessage{};
  out.stamp_ns = read_time(r);
  out.frame_id = r.string("frame_id");
  out.width = r.get<uint32_t>("width");
  out.height = r.get<uint32_t>("height");
  out.format = r.string("encoding");
  out.step = r.get<uint32_t>("step");
  out.data = r.bytes("data", out.bytes);
  EF_RETURN_IF_ERROR(checked(r, "RawImage", where));
  if (static_cast<uint64_t>(out.step) * out.height != out.bytes)
    return error(ErrorCode::kCorruptData, where + ": RawImage of " + std::to_string(out.width) + "x" +
                                              std::to_string(out.height) + " with step " + std::to_string(out.step) +
                                              " holds " + std::to_string(out.bytes) + " bytes");
  return Status::success();
}

Status decode_camera_calibration(const uint8_t* msg, std::size_t size, Calibration& out, const std::string& where) {
  cdr::Reader r(msg, size);
  out = Calibration{};
  out.stamp_ns = read_time(r);
  (void)r.string("frame_id");
  out.width = r.get<uint32_t>("width");
  out.height = r.get<uint32_t>("height");
  (void)r.string("distortion_model");
  const uint32_t nd = r.get<uint32_t>("d");
  for (uint32_t i = 0; i < nd && r.ok(); ++i) (void)r.get<double>("d");
  double k[9];
  for (double& v : k) v = r.get<double>("k");
  EF_RETURN_IF_ERROR(checked(r, "CameraCalibration", where));
  out.fx = k[0];
  out.cx = k[2];
  out.fy = k[4];
  out.cy = k[5];
  return Status::success();
}

Status decode_pose_in_frame(const uint8_t* msg, std::size_t size, PoseMessage& out, const std::string& where) {
  cdr::Reader r(msg, size);
  out = PoseMessage{};
  out.stamp_ns = read_time(r);
  (void)r.string("frame_id");
  double v[7];
  for (double& x : v) x = r.get<double>("pose");
  EF_RETURN_IF_ERROR(checked(r, "PoseInFrame", where));
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  if (!(q.norm() > 0.5 && q.norm() < 2))  // also NaN
    return error(ErrorCode::kCorruptData, where + ": PoseInFrame's orientation is not a rotation");
  out.T_wc = SE3(q, Eigen::Vector3d(v[0], v[1], v[2]));
  return Status::success();
}

}  // namespace ef::foxglove
