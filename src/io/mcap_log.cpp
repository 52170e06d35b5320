#include "io/mcap_log.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "io/image_codec.h"

namespace ef {

const opt::Table<McapLogOptions>& McapLogOptions::table() {
  static const opt::Table<McapLogOptions> t = {
      {"file", "", "--log", &McapLogOptions::file, "an .mcap file", opt::any(),
       "record a field log (MCAP: depth, colour, calibration, poses, labels, status; replay it with "
       "--source mcap:FILE); a relative name goes into the run folder; empty = no log"},
      {"depth", "", "--log-depth", &McapLogOptions::depth, "png | raw", opt::any(),
       "depth in the log: png (16-bit, lossless) or raw (16UC1: no encoding, 3x the bytes)"},
      {"color", "", "--log-color", &McapLogOptions::color, "jpeg | png | raw | none", opt::any(),
       "colour in the log: jpeg (lossy, small), png (lossless), raw (rgb8) or none"},
      {"color_every", "", "", &McapLogOptions::color_every, "frames", opt::between(1, 1000000),
       "colour of every n-th frame only"},
      {"jpeg_quality", "", "", &McapLogOptions::jpeg_quality, "", opt::between(1, 100), "JPEG quality of the colour"},
      {"png_level", "", "", &McapLogOptions::png_level, "", opt::between(1, 9),
       "zlib level of the PNG images (1 fastest, 9 smallest)"},
      {"chunk_seconds", "", "--log-chunk-seconds", &McapLogOptions::chunk_seconds, "s", opt::between(0.01, 3600),
       "a chunk of the log is closed and written after this much time: what a power cut may lose"},
      {"chunk_mb", "", "", &McapLogOptions::chunk_mb, "MB", opt::between(1, 1024),
       "and when it holds this much (its buffer, in the memory plan)"},
      {"sync", "", "", &McapLogOptions::sync, "", opt::any(),
       "fdatasync after each chunk (off: a kill loses nothing, a power cut may lose what the OS holds)"},
      {"map", "", "", &McapLogOptions::map, "", opt::any(),
       "the map as a PointCloud (/edgefusion/map) at each checkpoint, for Foxglove's 3D panel"},
  };
  return t;
}

Status McapLogOptions::validate() const {
  EF_RETURN_IF_ERROR(opt::check_table(*this, table(), "log"));
  if (depth != "png" && depth != "raw")
    return error(ErrorCode::kInvalidArgument, "log.depth '" + depth + "': expected png or raw");
  if (color != "jpeg" && color != "png" && color != "raw" && color != "none")
    return error(ErrorCode::kInvalidArgument, "log.color '" + color + "': expected jpeg, png, raw or none");
  return Status::success();
}

void depth_to_millimetres(const Image<float>& depth, uint16_t* dst) {
  const float* d = depth.data();
  const std::size_t n = depth.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double mm = std::isfinite(d[i]) && d[i] > 0 ? std::round(double(d[i]) * 1000.0) : 0.0;
    dst[i] = mm <= 65535.0 ? uint16_t(mm) : 0;
  }
}

McapFrameLog::~McapFrameLog() { (void)close(); }

std::size_t McapFrameLog::encoder_bytes_for(int width, int height) {
  // Millimetres, the PNG output and the message (both up to a raw colour image), the PNG encoder's
  // rows and zlib's state (about 268 kB at the default window and level 1).
  const std::size_t px = static_cast<std::size_t>(width) * height;
  return px * 2 + 2 * (PngEncoder::bytes_for(width, height, 3) + 256) + 2 * static_cast<std::size_t>(width) * 3 +
         268000;
}

std::size_t McapFrameLog::bytes_for(const McapLogOptions& options, int width, int height, int label_width,
                                    int label_height) {
  const std::size_t mapping = label_width > 0 ? encoder_bytes_for(label_width, label_height) : 4096;
  const std::size_t map = options.map ? kMapPiecePoints * 20 : 0;
  return static_cast<std::size_t>(options.chunk_mb) * 1000000 + encoder_bytes_for(width, height) + mapping + map;
}

Status McapFrameLog::open(const std::string& path, const McapLogOptions& options, int width, int height,
                          const Intrinsics& intrinsics) {
  EF_RETURN_IF_ERROR(options.validate());
  std::lock_guard<std::mutex> lock(mutex_);
  options_ = options;
  path_ = path;
  width_ = width;
  height_ = height;
  intrinsics_ = intrinsics;
  McapWriterOptions w;
  w.chunk_seconds = options.chunk_seconds;
  w.chunk_bytes = static_cast<std::size_t>(options.chunk_mb) * 1000000;
  w.sync = options.sync;
  EF_RETURN_IF_ERROR(writer_.open(path, w));
  const auto schema = [&](const foxglove::SchemaText& s) { return writer_.add_schema(s.name, "ros2msg", s.definition); };
  auto compressed = schema(foxglove::compressed_image_schema());
  if (!compressed.ok()) return compressed.error();
  auto raw = schema(foxglove::raw_image_schema());
  if (!raw.ok()) return raw.error();
  auto calibration = schema(foxglove::camera_calibration_schema());
  if (!calibration.ok()) return calibration.error();
  auto pose = schema(foxglove::pose_in_frame_schema());
  if (!pose.ok()) return pose.error();
  auto tf = schema(foxglove::frame_transform_schema());
  if (!tf.ok()) return tf.error();
  auto log = schema(foxglove::log_schema());
  if (!log.ok()) return log.error();
  auto cloud = schema(foxglove::point_cloud_schema());
  if (!cloud.ok()) return cloud.error();
  const struct {
    Channel c;
    uint16_t schema;
    const char* topic;
  } channels[] = {
      {kCalibration, *calibration, "/camera/calibration"},
      {kDepth, options.depth == "raw" ? *raw : *compressed, "/camera/depth"},
      {kColor, options.color == "raw" ? *raw : *compressed, "/camera/color"},
      {kReferencePose, *pose, "/camera/reference_pose"},
      {kPose, *pose, "/edgefusion/pose"},
      {kTf, *tf, "/tf"},
      {kLabels, *compressed, "/edgefusion/labels"},
      {kLog, *log, "/log"},
      {kMap, *cloud, "/edgefusion/map"},
  };
  for (const auto& ch : channels) {
    if ((ch.c == kColor && options.color == "none") || (ch.c == kMap && !options.map)) continue;
    auto id = writer_.add_channel(ch.schema, ch.topic, "cdr");
    if (!id.ok()) return id.error();
    channel_[ch.c] = *id;
  }
  if (options.map) {
    map_piece_.resize(kMapPiecePoints * 20);
    map_head_.reserve(512);
  }
  open_ = true;
  failed_.reset();
  calibration_written_ = false;
  frames_ = 0;
  return Status::success();
}

std::unique_ptr<McapFrameLog::Encoder> McapFrameLog::make_encoder(bool with_images, int width, int height) const {
  if (width <= 0 || height <= 0) {
    width = width_;
    height = height_;
  }
  auto e = std::make_unique<Encoder>();
  if (!with_images) {
    e->message.reserve(4096);  // poses and status lines
    return e;
  }
  e->png = std::make_unique<PngEncoder>(width, height, 3, static_cast<int>(options_.png_level));
  e->millimetres.resize(static_cast<std::size_t>(width) * height);
  const std::size_t most = PngEncoder::bytes_for(width, height, 3) + 256;
  e->image.reserve(most);
  e->message.reserve(most);
  return e;
}

Status McapFrameLog::put(uint16_t channel, uint64_t stamp_ns, const std::string& message) {
  // Under the lock.
  if (failed_) return *failed_;
  Status s = writer_.write(channel, stamp_ns, stamp_ns, message.data(), message.size());
  if (!s.ok()) failed_ = s.error();
  return s;
}

Status McapFrameLog::log_frame(const Frame& frame, Encoder& enc) {
  if (!open_ || !enc.png) return error(ErrorCode::kInvalidArgument, "field log: log_frame() before open() or without images");
  if (frame.depth.width() != width_ || frame.depth.height() != height_)
    return error(ErrorCode::kInvalidArgument, path_ + ": a frame of " + std::to_string(frame.depth.width()) + "x" +
                                                  std::to_string(frame.depth.height()) + " in a log of " +
                                                  std::to_string(width_) + "x" + std::to_string(height_));
  const uint64_t ns = foxglove::to_nanoseconds(frame.timestamp);
  const uint32_t w = static_cast<uint32_t>(width_), h = static_cast<uint32_t>(height_);
  // Calibration, once, before the first frame (under the lock: one thread writes it).
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!calibration_written_) {
      foxglove::encode_camera_calibration(ns, "camera", w, h, intrinsics_.fx, intrinsics_.fy, intrinsics_.cx,
                                          intrinsics_.cy, enc.message);
      EF_RETURN_IF_ERROR(put(channel_[kCalibration], ns, enc.message));
      calibration_written_ = true;
    }
  }
  // Depth.
  if (options_.depth == "raw") {
    // Converted beside and copied in: the pixels' place in the message need not be 2-byte aligned.
    depth_to_millimetres(frame.depth, enc.millimetres.data());
    foxglove::encode_raw_image(ns, "camera", w, h, "16UC1", w * 2, enc.millimetres.data(), enc.message);
  } else {
    depth_to_millimetres(frame.depth, enc.millimetres.data());
    EF_RETURN_IF_ERROR(enc.png->encode(ImageView<const uint16_t>(enc.millimetres.data(), width_, height_,
                                                                 static_cast<std::size_t>(width_) * 2),
                                       enc.image));
    foxglove::encode_compressed_image(ns, "camera", enc.image.data(), enc.image.size(), "png", enc.message);
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    EF_RETURN_IF_ERROR(put(channel_[kDepth], ns, enc.message));
  }
  // Colour, when due.
  const bool color_due = options_.color != "none" && !frame.color.empty() &&
                         frame.index % options_.color_every == 0;
  if (color_due) {
    const ImageView<const Rgb8> c = frame.color.view();
    if (options_.color == "raw") {
      foxglove::encode_raw_image(ns, "camera", w, h, "rgb8", w * 3, nullptr, enc.message);
      char* dst = foxglove::raw_image_data(enc.message, h, w * 3);
      for (int y = 0; y < height_; ++y) std::memcpy(dst + static_cast<std::size_t>(y) * w * 3, c.row(y), w * 3);
    } else {
      if (options_.color == "png")
        EF_RETURN_IF_ERROR(enc.png->encode(c, enc.image));
      else
        EF_RETURN_IF_ERROR(encode_jpeg(c, static_cast<int>(options_.jpeg_quality), enc.image));
      foxglove::encode_compressed_image(ns, "camera", enc.image.data(), enc.image.size(), options_.color, enc.message);
    }
    std::lock_guard<std::mutex> lock(mutex_);
    EF_RETURN_IF_ERROR(put(channel_[kColor], ns, enc.message));
  }
  if (frame.has_pose) {
    foxglove::encode_pose_in_frame(ns, "world", frame.T_wc, enc.message);
    std::lock_guard<std::mutex> lock(mutex_);
    EF_RETURN_IF_ERROR(put(channel_[kReferencePose], ns, enc.message));
  }
  std::lock_guard<std::mutex> lock(mutex_);
  ++frames_;
  return Status::success();
}

Status McapFrameLog::log_pose(double timestamp, const SE3& T_wc, Encoder& enc) {
  if (!open_) return error(ErrorCode::kInvalidArgument, "field log: log_pose() before open()");
  const uint64_t ns = foxglove::to_nanoseconds(timestamp);
  foxglove::encode_pose_in_frame(ns, "world", T_wc, enc.message);
  std::lock_guard<std::mutex> lock(mutex_);
  EF_RETURN_IF_ERROR(put(channel_[kPose], ns, enc.message));
  foxglove::encode_frame_transform(ns, "world", "camera", T_wc, enc.message);
  return put(channel_[kTf], ns, enc.message);
}

Status McapFrameLog::log_labels(double timestamp, ImageView<const uint8_t> labels, Encoder& enc) {
  if (!open_ || !enc.png) return error(ErrorCode::kInvalidArgument, "field log: log_labels() before open() or without images");
  const uint64_t ns = foxglove::to_nanoseconds(timestamp);
  EF_RETURN_IF_ERROR(enc.png->encode(labels, enc.image));
  foxglove::encode_compressed_image(ns, "camera", enc.image.data(), enc.image.size(), "png", enc.message);
  std::lock_guard<std::mutex> lock(mutex_);
  return put(channel_[kLabels], ns, enc.message);
}

Status McapFrameLog::log_text(double timestamp, foxglove::LogLevel level, std::string_view text, Encoder& enc) {
  if (!open_) return error(ErrorCode::kInvalidArgument, "field log: log_text() before open()");
  const uint64_t ns = foxglove::to_nanoseconds(timestamp);
  foxglove::encode_log(ns, level, text, "edgefusion", enc.message);
  std::lock_guard<std::mutex> lock(mutex_);
  return put(channel_[kLog], ns, enc.message);
}

Status McapFrameLog::log_map(double timestamp, const SurfelCloudView& cloud) {
  if (!open_ || !options_.map) return Status::success();
  const bool classes = cloud.class_id.data != nullptr;
  static constexpr foxglove::PackedField kFields[] = {
      {"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}, {"red", 12, 1}, {"green", 13, 1}, {"blue", 14, 1}, {"alpha", 15, 1},
      {"class", 16, 1}};
  const uint32_t stride = classes ? 17 : 16;
  const uint64_t ns = foxglove::to_nanoseconds(timestamp);
  std::lock_guard<std::mutex> lock(mutex_);
  if (failed_) return *failed_;
  foxglove::encode_point_cloud_head(ns, "world", stride, kFields, classes ? 8 : 7, cloud.count, map_head_);
  const uint64_t bytes = map_head_.size() + uint64_t(cloud.count) * stride;
  Status s = writer_.write_streamed(channel_[kMap], ns, bytes, [&](const McapWriter::Put& put) -> Status {
    EF_RETURN_IF_ERROR(put(map_head_.data(), map_head_.size()));
    for (std::size_t first = 0; first < cloud.count; first += kMapPiecePoints) {
      const std::size_t n = std::min<std::size_t>(kMapPiecePoints, cloud.count - first);
      uint8_t* p = map_piece_.data();
      for (std::size_t i = first; i < first + n; ++i, p += stride) {
        const float xyz[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
        std::memcpy(p, xyz, 12);
        p[12] = cloud.red[i];
        p[13] = cloud.green[i];
        p[14] = cloud.blue[i];
        p[15] = 255;
        if (classes) p[16] = cloud.class_id[i];
      }
      EF_RETURN_IF_ERROR(put(map_piece_.data(), n * stride));
    }
    return Status::success();
  });
  if (!s.ok()) failed_ = s.error();
  return s;
}

Status McapFrameLog::flush() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!open_) return Status::success();
  if (failed_) return *failed_;
  Status s = writer_.flush();
  if (!s.ok()) failed_ = s.error();
  return s;
}

Status McapFrameLog::close() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!open_) return Status::success();
  open_ = false;
  if (failed_) {
    writer_.abandon();  // the file ends after its last whole chunk
    return *failed_;
  }
  return writer_.close();
}

uint64_t McapFrameLog::frames() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return frames_;
}

uint64_t McapFrameLog::messages() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return writer_.messages();
}

}  // namespace ef
