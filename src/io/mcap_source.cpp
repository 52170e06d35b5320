#include "io/mcap_source.h"

#include <cstdio>
#include <cstring>
#include <unordered_map>
#include <vector>

#include "io/foxglove_msgs.h"
#include "io/image_codec.h"
#include "io/mcap_reader.h"
#include "kernels/depth_convert.h"

namespace ef {

namespace {

class McapSource final : public FrameSource {
 public:
  Status init(std::unique_ptr<McapReader> reader, const std::string& uri, const std::string& depth_topic,
              const std::string& color_topic) {
    reader_ = std::move(reader);
    info_.uri = uri;
    info_.warning = reader_->warning();
    const McapChannel* depth = reader_->channel(depth_topic);
    if (depth == nullptr) return fault("has no depth topic '" + depth_topic + "'" + topics());
    depth_raw_ = schema_is(*depth, "foxglove_msgs/msg/RawImage");
    if (!depth_raw_ && !schema_is(*depth, "foxglove_msgs/msg/CompressedImage"))
      return fault("topic '" + depth_topic + "' is not a foxglove_msgs RawImage or CompressedImage");
    const McapChannel* color = reader_->channel(color_topic);
    if (color != nullptr) {
      color_raw_ = schema_is(*color, "foxglove_msgs/msg/RawImage");
      if (!color_raw_ && !schema_is(*color, "foxglove_msgs/msg/CompressedImage"))
        return fault("topic '" + color_topic + "' is not a foxglove_msgs RawImage or CompressedImage");
    }
    const McapChannel* calibration = reader_->channel("/camera/calibration");
    const McapChannel* reference = reader_->channel("/camera/reference_pose");
    // Colour and reference poses by timestamp; frames in the depth topic's order.
    std::unordered_map<uint64_t, std::size_t> color_at, pose_at;
    bool have_calibration = false;
    foxglove::Calibration calib;
    std::string buf;
    const auto& messages = reader_->messages();
    for (std::size_t i = 0; i < messages.size(); ++i) {
      const McapMessageRef& m = messages[i];
      if (depth != nullptr && m.channel == depth->id) {
        frames_.push_back({i, SIZE_MAX, SIZE_MAX});
      } else if (color != nullptr && m.channel == color->id) {
        color_at[m.log_time] = i;
      } else if (reference != nullptr && m.channel == reference->id) {
        pose_at[m.log_time] = i;
      } else if (calibration != nullptr && m.channel == calibration->id) {
        EF_RETURN_IF_ERROR(reader_->read(m, buf));
        foxglove::Calibration c;
        EF_RETURN_IF_ERROR(foxglove::decode_camera_calibration(reinterpret_cast<const uint8_t*>(buf.data()),
                                                               buf.size(), c, where(m)));
        if (!have_calibration) {
          calib = c;
          have_calibration = true;
        } else if (c.width != calib.width || c.height != calib.height || c.fx != calib.fx || c.fy != calib.fy ||
                   c.cx != calib.cx || c.cy != calib.cy) {
          return fault("its camera calibration changes at " + where(m) + " (one camera per log is replayed)");
        }
      }
    }
    if (!have_calibration) return fault("has no /camera/calibration message (the intrinsics)");
    // Frames are allocated at this size (a frame without colour gets a black image of it): bounded.
    if (calib.width == 0 || calib.height == 0 || calib.width > 8192 || calib.height > 8192 ||
        uint64_t(calib.width) * calib.height > (uint64_t(1) << 24) || !(calib.fx > 0) || !(calib.fy > 0))
      return fault("its camera calibration is not a usable pinhole camera (" + std::to_string(calib.width) + "x" +
                   std::to_string(calib.height) + ", fx " + std::to_string(calib.fx) + ")");
    if (frames_.empty()) return fault("has no message on its depth topic '" + depth_topic + "'" +
                                      (info_.warning.empty() ? "" : ": " + info_.warning));
    for (Entry& e : frames_) {
      const uint64_t t = messages[e.depth].log_time;
      if (auto it = color_at.find(t); it != color_at.end()) e.color = it->second;
      if (auto it = pose_at.find(t); it != pose_at.end()) e.pose = it->second;
    }
    info_.intrinsics = Intrinsics{static_cast<float>(calib.fx), static_cast<float>(calib.fy),
                                  static_cast<float>(calib.cx), static_cast<float>(calib.cy),
                                  static_cast<int>(calib.width), static_cast<int>(calib.height)};
    info_.intrinsics_from = "the log's /camera/calibration";
    info_.frame_count = static_cast<int64_t>(frames_.size());
    info_.has_color = color != nullptr;
    info_.has_pose = reference != nullptr && !pose_at.empty();
    if (frames_.size() >= 2) {  // the rate the log was recorded at, for --realtime
      const double span = double(messages[frames_.back().depth].log_time - messages[frames_.front().depth].log_time);
      if (span > 0) info_.nominal_fps = double(frames_.size() - 1) / (span * 1e-9);
    }
    return Status::success();
  }

  const SourceInfo& info() const override { return info_; }

  Result<bool> next(Frame& out) override {
    if (next_ >= frames_.size()) return false;
    const Entry& e = frames_[next_];
    const auto& messages = reader_->messages();
    const McapMessageRef& dm = messages[e.depth];
    const int w = info_.intrinsics.width, h = info_.intrinsics.height;
    // Depth.
    EF_RETURN_IF_ERROR(reader_->read(dm, message_));
    foxglove::ImageMessage img;
    const auto* bytes = reinterpret_cast<const uint8_t*>(message_.data());
    if (depth_raw_) {
      EF_RETURN_IF_ERROR(foxglove::decode_raw_image(bytes, message_.size(), img, where(dm)));
      if (img.format != "16UC1" && img.format != "mono16")
        return frame_fault(dm, "depth encoded '" + std::string(img.format) + "' (expected 16UC1 or mono16)");
      if (int(img.width) != w || int(img.height) != h || img.step != img.width * 2)
        return frame_fault(dm, "a depth image of " + std::to_string(img.width) + "x" + std::to_string(img.height) +
                                   " in a log calibrated for " + std::to_string(w) + "x" + std::to_string(h));
      millimetres_.allocate(w, h);
      std::memcpy(millimetres_.data(), img.data, img.bytes);
    } else {
      EF_RETURN_IF_ERROR(foxglove::decode_compressed_image(bytes, message_.size(), img, where(dm)));
      if (img.format != "png") return frame_fault(dm, "depth compressed as '" + std::string(img.format) + "' (expected png)");
      EF_RETURN_IF_ERROR(decode_png_u16(img.data, img.bytes, millimetres_, where(dm) + " (depth)"));
      if (millimetres_.width() != w || millimetres_.height() != h)
        return frame_fault(dm, "a depth image of " + std::to_string(millimetres_.width()) + "x" +
                                   std::to_string(millimetres_.height()) + " in a log calibrated for " +
                                   std::to_string(w) + "x" + std::to_string(h));
    }
    out.depth.allocate(w, h);
    kernels::depth_u16_to_metres(millimetres_.data(), out.depth.data(), millimetres_.size(), 0.001f, 65535);
    // Colour.
    if (info_.has_color) {
      if (e.color == SIZE_MAX) {
        out.color.allocate(w, h);
        std::memset(static_cast<void*>(out.color.data()), 0, out.color.size() * sizeof(Rgb8));
      } else {
        const McapMessageRef& cm = messages[e.color];
        EF_RETURN_IF_ERROR(reader_->read(cm, message_));
        bytes = reinterpret_cast<const uint8_t*>(message_.data());
        if (color_raw_) {
          EF_RETURN_IF_ERROR(foxglove::decode_raw_image(bytes, message_.size(), img, where(cm)));
          if (img.format != "rgb8") return frame_fault(cm, "colour encoded '" + std::string(img.format) + "' (expected rgb8)");
          if (int(img.width) != w || int(img.height) != h || img.step != img.width * 3)
            return frame_fault(cm, "a colour image of " + std::to_string(img.width) + "x" + std::to_string(img.height));
          out.color.allocate(w, h);
          std::memcpy(static_cast<void*>(out.color.data()), img.data, img.bytes);
        } else {
          EF_RETURN_IF_ERROR(foxglove::decode_compressed_image(bytes, message_.size(), img, where(cm)));
          if (img.format == "jpeg")
            EF_RETURN_IF_ERROR(decode_jpeg(img.data, img.bytes, out.color, where(cm) + " (colour)"));
          else if (img.format == "png")
            EF_RETURN_IF_ERROR(decode_png_rgb(img.data, img.bytes, out.color, where(cm) + " (colour)"));
          else
            return frame_fault(cm, "colour compressed as '" + std::string(img.format) + "' (expected jpeg or png)");
          if (out.color.width() != w || out.color.height() != h)
            return frame_fault(cm, "a colour image of " + std::to_string(out.color.width()) + "x" +
                                       std::to_string(out.color.height()));
        }
      }
    } else {
      out.color = Image<Rgb8>();
    }
    // Reference pose.
    out.has_pose = false;
    if (e.pose != SIZE_MAX) {
      const McapMessageRef& pm = messages[e.pose];
      EF_RETURN_IF_ERROR(reader_->read(pm, message_));
      foxglove::PoseMessage p;
      EF_RETURN_IF_ERROR(foxglove::decode_pose_in_frame(reinterpret_cast<const uint8_t*>(message_.data()),
                                                        message_.size(), p, where(pm)));
      out.T_wc = p.T_wc;
      out.has_pose = true;
    }
    out.has_labels = false;
    out.timestamp = double(dm.log_time) * 1e-9;
    out.index = static_cast<int64_t>(next_);
    char name[32];
    std::snprintf(name, sizeof name, "frame-%06lld", static_cast<long long>(next_));
    out.name.assign(name);
    ++next_;
    return true;
  }

  Result<int64_t> skip(int64_t n, Frame&) override {  // the index makes skipping free
    const int64_t left = static_cast<int64_t>(frames_.size() - next_);
    const int64_t k = n < left ? n : left;
    next_ += static_cast<std::size_t>(k);
    return k;
  }

 private:
  struct Entry {
    std::size_t depth, color, pose;  // indexes into the reader's messages; SIZE_MAX = none
  };
  bool schema_is(const McapChannel& c, const char* name) const {
    const McapSchema* s = reader_->schema(c.schema_id);
    return s != nullptr && s->name == name;
  }
  std::string where(const McapMessageRef& m) const {
    return reader_->name() + ": message at byte " + std::to_string(m.offset);
  }
  std::string topics() const {
    std::string t = " (it has:";
    for (const McapChannel& c : reader_->channels()) t += " " + c.topic;
    return t + ")";
  }
  Error fault(const std::string& what) const { return error(ErrorCode::kCorruptData, reader_->name() + ": " + what); }
  Error frame_fault(const McapMessageRef& m, const std::string& what) const {
    return error(ErrorCode::kCorruptData, where(m) + " (frame " + std::to_string(next_) + "): " + what);
  }

  std::unique_ptr<McapReader> reader_;
  SourceInfo info_;
  std::vector<Entry> frames_;
  std::size_t next_ = 0;
  bool depth_raw_ = false, color_raw_ = false;
  std::string message_;
  Image<uint16_t> millimetres_;
};

Result<std::unique_ptr<FrameSource>> make(std::unique_ptr<McapReader> reader, const std::string& uri,
                                          const std::string& depth, const std::string& color) {
  auto source = std::make_unique<McapSource>();
  EF_RETURN_IF_ERROR(source->init(std::move(reader), uri, depth, color));
  return std::unique_ptr<FrameSource>(std::move(source));
}

}  // namespace

Result<std::unique_ptr<FrameSource>> open_mcap(const SourceUri& uri) {
  EF_RETURN_IF_ERROR(check_query_keys(uri, {"depth", "color"}));
  if (uri.path.empty()) return error(ErrorCode::kInvalidArgument, "mcap: needs a file (mcap:FILE.mcap)");
  auto reader = std::make_unique<McapReader>();
  EF_RETURN_IF_ERROR(reader->open(uri.path));
  const auto q = [&](const char* k, const char* d) {
    auto it = uri.query.find(k);
    return it == uri.query.end() ? std::string(d) : it->second;
  };
  return make(std::move(reader), "mcap:" + uri.path, q("depth", "/camera/depth"), q("color", "/camera/color"));
}

Result<std::unique_ptr<FrameSource>> open_mcap_memory(const uint8_t* data, std::size_t size, const std::string& name) {
  auto reader = std::make_unique<McapReader>();
  EF_RETURN_IF_ERROR(reader->open_memory(data, size, name));
  return make(std::move(reader), "mcap:" + name, "/camera/depth", "/camera/color");
}

}  // namespace ef
