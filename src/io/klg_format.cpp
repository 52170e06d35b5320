#include "io/klg_format.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>

#include <unistd.h>
#include <zlib.h>

#include "io/durable_file.h"
#include "io/image_codec.h"
#include "io/text_parse.h"
#include "kernels/depth_convert.h"

namespace ef {

namespace {

constexpr std::size_t kFrameHeaderBytes = 16;  // int64 timestamp, int32 depth size, int32 image size
constexpr int kMaxSide = 16384;                // pixels

int32_t load_le32(const uint8_t* p) {
  return static_cast<int32_t>(uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24);
}
int64_t load_le64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return static_cast<int64_t>(v);
}
void store_le32(uint8_t* p, int32_t v) {
  const uint32_t u = static_cast<uint32_t>(v);
  for (int i = 0; i < 4; ++i) p[i] = uint8_t(u >> (8 * i));
}
void store_le64(uint8_t* p, int64_t v) {
  const uint64_t u = static_cast<uint64_t>(v);
  for (int i = 0; i < 8; ++i) p[i] = uint8_t(u >> (8 * i));
}

// Random-access bytes: a file or memory.
class ByteInput {
 public:
  virtual ~ByteInput() = default;
  virtual uint64_t size() const = 0;
  // Reads exactly n bytes at offset; false when that fails (callers have checked the size).
  virtual bool read_at(uint64_t offset, uint8_t* dst, std::size_t n) = 0;
};

class FileInput final : public ByteInput {
 public:
  FileInput(std::FILE* f, uint64_t size) : f_(f), size_(size) {}
  ~FileInput() override { std::fclose(f_); }
  uint64_t size() const override { return size_; }
  bool read_at(uint64_t offset, uint8_t* dst, std::size_t n) override {
    if (offset != pos_) {
      if (fseeko(f_, static_cast<off_t>(offset), SEEK_SET) != 0) return false;
      pos_ = offset;
    }
    const std::size_t got = std::fread(dst, 1, n, f_);
    pos_ += got;
    return got == n;
  }

 private:
  std::FILE* f_;
  uint64_t size_;
  uint64_t pos_ = 0;
};

class MemoryInput final : public ByteInput {
 public:
  MemoryInput(const uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  uint64_t size() const override { return size_; }
  bool read_at(uint64_t offset, uint8_t* dst, std::size_t n) override {
    if (offset > size_ || n > size_ - offset) return false;
    if (n) std::memcpy(dst, data_ + offset, n);
    return true;
  }

 private:
  const uint8_t* data_;
  std::size_t size_;
};

// Width and height from a JPEG's frame header (SOFn), without decoding. False when the bytes do
// not reach a frame header.
bool jpeg_frame_size(const uint8_t* p, std::size_t n, int& width, int& height) {
  if (n < 4 || p[0] != 0xFF || p[1] != 0xD8) return false;
  std::size_t pos = 2;
  while (pos + 4 <= n) {
    if (p[pos] != 0xFF) return false;
    while (pos + 1 < n && p[pos + 1] == 0xFF) ++pos;  // fill bytes
    if (pos + 4 > n) return false;
    const uint8_t marker = p[pos + 1];
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) {  // standalone markers
      pos += 2;
      continue;
    }
    if (marker == 0xD9 || marker == 0xDA) return false;  // end of image / start of scan first
    const std::size_t len = (std::size_t(p[pos + 2]) << 8) | p[pos + 3];
    if (len < 2) return false;
    const bool sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (sof) {
      if (len < 7 || pos + 9 > n) return false;
      height = (int(p[pos + 5]) << 8) | p[pos + 6];
      width = (int(p[pos + 7]) << 8) | p[pos + 8];
      return true;
    }
    pos += 2 + len;
  }
  return false;
}

class KlgSource final : public FrameSource {
 public:
  struct FrameIndex {
    uint64_t offset;  // of the frame header, bytes from the start of the file
    int64_t timestamp_us;
    int32_t depth_size, image_size;  // bytes
  };

  KlgSource(SourceInfo info, std::string name, std::unique_ptr<ByteInput> input, std::vector<FrameIndex> frames)
      : info_(std::move(info)), name_(std::move(name)), input_(std::move(input)), frames_(std::move(frames)) {
    const std::size_t px = std::size_t(info_.intrinsics.width) * std::size_t(info_.intrinsics.height);
    depth_bytes_.reserve(px * 2);
    color_bytes_.reserve(px * 3);
    depth_mm_.resize(px);
  }

  const SourceInfo& info() const override { return info_; }

  Result<int64_t> skip(int64_t n, Frame& /*scratch*/) override {
    const int64_t left = static_cast<int64_t>(frames_.size() - std::min(next_, frames_.size()));
    const int64_t skipped = std::min(std::max<int64_t>(n, 0), left);
    next_ += static_cast<std::size_t>(skipped);
    return skipped;
  }

  Result<bool> next(Frame& out) override {
    if (next_ >= frames_.size()) return false;
    const std::size_t idx = next_;
    const FrameIndex& f = frames_[idx];
    const int w = info_.intrinsics.width, h = info_.intrinsics.height;
    const std::size_t px = std::size_t(w) * std::size_t(h);
    const auto fail = [&](ErrorCode code, const std::string& what) {
      return error(code, "klg file '" + name_ + "', frame " + std::to_string(idx) + " at byte " +
                             std::to_string(f.offset) + ": " + what);
    };
    const uint64_t depth_at = f.offset + kFrameHeaderBytes;
    depth_bytes_.resize(std::size_t(f.depth_size));
    if (!input_->read_at(depth_at, depth_bytes_.data(), depth_bytes_.size()))
      return fail(ErrorCode::kIoError, "cannot read the depth bytes");
    if (std::size_t(f.depth_size) == px * 2) {
      for (std::size_t i = 0; i < px; ++i)
        depth_mm_[i] = uint16_t(depth_bytes_[2 * i] | (uint16_t(depth_bytes_[2 * i + 1]) << 8));
    } else {
      uLongf len = static_cast<uLongf>(px * 2);
      const int rc = uncompress(reinterpret_cast<Bytef*>(depth_mm_.data()), &len, depth_bytes_.data(),
                                static_cast<uLong>(depth_bytes_.size()));
      if (rc != Z_OK || len != px * 2) {
        const std::string why = rc == Z_OK       ? "inflates to " + std::to_string(len) + " bytes"
                                : rc == Z_BUF_ERROR ? "is truncated or inflates to more than " + std::to_string(px * 2) + " bytes"
                                : rc == Z_MEM_ERROR ? "cannot be inflated (out of memory)"
                                                    : "is not a valid zlib stream";
        return fail(ErrorCode::kCorruptData, "compressed depth (" + std::to_string(f.depth_size) + " bytes) " + why +
                                                 ", expected " + std::to_string(px * 2) + " bytes for " +
                                                 std::to_string(w) + "x" + std::to_string(h) +
                                                 " (is the size right? pass ?size=WxH)");
      }
      if (!host_is_little_endian())
        for (auto& v : depth_mm_) v = uint16_t((v >> 8) | (v << 8));
    }
    out.depth.allocate(w, h);
    kernels::depth_u16_to_metres(depth_mm_.data(), out.depth.data(), px, 0.001f, 65535);

    const uint64_t color_at = depth_at + uint64_t(f.depth_size);
    if (f.image_size == 0) {
      if (info_.has_color) {
        out.color.allocate(w, h);
        out.color.fill(Rgb8{0, 0, 0});
      } else if (!out.color.empty()) {
        out.color = Image<Rgb8>();
      }
    } else {
      color_bytes_.resize(std::size_t(f.image_size));
      if (!input_->read_at(color_at, color_bytes_.data(), color_bytes_.size()))
        return fail(ErrorCode::kIoError, "cannot read the colour bytes");
      out.color.allocate(w, h);
      if (std::size_t(f.image_size) == px * 3) {
        std::memcpy(out.color.data(), color_bytes_.data(), px * 3);
      } else {
        int jw = 0, jh = 0;
        if (!jpeg_frame_size(color_bytes_.data(), color_bytes_.size(), jw, jh))
          return fail(ErrorCode::kCorruptData, "colour (" + std::to_string(f.image_size) +
                                                   " bytes, neither raw nor empty) is not a JPEG with a frame header");
        if (jw != w || jh != h)
          return fail(ErrorCode::kCorruptData, "colour JPEG is " + std::to_string(jw) + "x" + std::to_string(jh) +
                                                   ", expected " + std::to_string(w) + "x" + std::to_string(h));
        Status s = decode_jpeg(color_bytes_.data(), color_bytes_.size(), out.color, "colour JPEG");
        if (!s.ok()) return fail(ErrorCode::kCorruptData, s.error().message);
        if (out.color.width() != w || out.color.height() != h)
          return fail(ErrorCode::kCorruptData, "colour JPEG decodes to the wrong size");
      }
    }
    out.timestamp = double(f.timestamp_us) * 1e-6;
    out.index = int64_t(idx);
    out.has_pose = false;
    out.T_wc = SE3();
    out.has_labels = false;
    char stem[32];
    std::snprintf(stem, sizeof(stem), "frame-%06llu", static_cast<unsigned long long>(idx));
    out.name.assign(stem);
    ++next_;
    return true;
  }

 private:
  static bool host_is_little_endian() {
    const uint16_t one = 1;
    uint8_t b;
    std::memcpy(&b, &one, 1);
    return b == 1;
  }

  SourceInfo info_;
  std::string name_;
  std::unique_ptr<ByteInput> input_;
  std::vector<FrameIndex> frames_;
  std::vector<uint8_t> depth_bytes_;  // as stored, reused
  std::vector<uint8_t> color_bytes_;  // as stored, reused
  std::vector<uint16_t> depth_mm_;    // W*H millimetres, host order, reused
  std::size_t next_ = 0;
};

// Walks the frame headers and builds the source; every structural fault is reported here.
Result<std::unique_ptr<FrameSource>> open_klg_input(std::unique_ptr<ByteInput> input, const std::string& name,
                                                    int width, int height, const SourceUri* uri,
                                                    const Intrinsics* side) {
  if (width <= 0 || height <= 0 || width > kMaxSide || height > kMaxSide)
    return error(ErrorCode::kInvalidArgument, "klg file '" + name + "': size " + std::to_string(width) + "x" +
                                                  std::to_string(height) + " out of range");
  const uint64_t file_size = input->size();
  const auto at = [&](uint64_t offset) { return "klg file '" + name + "' at byte " + std::to_string(offset) + ": "; };
  uint8_t hdr[kFrameHeaderBytes];
  if (file_size < 4 || !input->read_at(0, hdr, 4))
    return error(ErrorCode::kCorruptData, at(0) + "truncated: the file has " + std::to_string(file_size) +
                                              " bytes, fewer than the 4-byte frame count");
  const int32_t count = load_le32(hdr);
  if (count < 0)
    return error(ErrorCode::kCorruptData, at(0) + "negative frame count " + std::to_string(count));
  const uint64_t max_depth = uint64_t(width) * uint64_t(height) * 2;
  const uint64_t max_color = uint64_t(width) * uint64_t(height) * 3;
  const std::string size_text = std::to_string(width) + "x" + std::to_string(height);

  std::vector<KlgSource::FrameIndex> frames;
  frames.reserve(std::size_t(std::min<uint64_t>(uint64_t(count), (file_size - 4) / kFrameHeaderBytes)));
  uint64_t offset = 4;
  bool any_color = false;
  // Every whole frame in the file, counted or not: a recording cut while written (a kill, a power
  // cut) has fewer frames than its count says, or more when the count was not yet updated. A part
  // frame at the end stops the walk; anything else malformed is an error.
  while (file_size - offset >= kFrameHeaderBytes) {
    const int64_t i = static_cast<int64_t>(frames.size());
    const auto frame_at = [&](uint64_t off) {
      return "klg file '" + name + "', frame " + std::to_string(i) + " at byte " + std::to_string(off) + ": ";
    };
    const auto beyond_count = [&] {
      return error(ErrorCode::kCorruptData, at(offset) + std::to_string(file_size - offset) +
                                                " bytes after the last of " + std::to_string(count) +
                                                " frames that are not frames (wrong frame count or size?)");
    };
    if (!input->read_at(offset, hdr, kFrameHeaderBytes))
      return error(ErrorCode::kIoError, frame_at(offset) + "cannot read the frame header");
    KlgSource::FrameIndex f;
    f.offset = offset;
    f.timestamp_us = load_le64(hdr);
    f.depth_size = load_le32(hdr + 8);
    f.image_size = load_le32(hdr + 12);
    if (f.depth_size <= 0 || uint64_t(f.depth_size) > max_depth) {
      if (i >= count && count > 0) return beyond_count();
      return error(ErrorCode::kCorruptData, frame_at(offset) + "depth size " + std::to_string(f.depth_size) +
                                                " not in 1.." + std::to_string(max_depth) + " (" + size_text +
                                                "x2 bytes; is the size right? pass ?size=WxH)");
    }
    if (f.image_size < 0 || uint64_t(f.image_size) > max_color) {
      if (i >= count && count > 0) return beyond_count();
      return error(ErrorCode::kCorruptData, frame_at(offset) + "image size " + std::to_string(f.image_size) +
                                                " not in 0.." + std::to_string(max_color) + " (" + size_text +
                                                "x3 bytes; is the size right? pass ?size=WxH)");
    }
    if (!frames.empty() && f.timestamp_us < frames.back().timestamp_us) {
      if (i >= count && count > 0) return beyond_count();
      return error(ErrorCode::kCorruptData, frame_at(offset) + "timestamp " + std::to_string(f.timestamp_us) +
                                                " us is before the previous frame's " +
                                                std::to_string(frames.back().timestamp_us) + " us");
    }
    const uint64_t payload = uint64_t(f.depth_size) + uint64_t(f.image_size);
    if (file_size - offset - kFrameHeaderBytes < payload) {
      if (!frames.empty()) break;  // a part frame at the end: cut
      return error(ErrorCode::kCorruptData, frame_at(offset) + "truncated: " + std::to_string(payload) +
                                                " bytes of depth and colour run past the end of the file at byte " +
                                                std::to_string(file_size) + " (no whole frame to read)");
    }
    any_color = any_color || f.image_size > 0;
    frames.push_back(f);
    offset += kFrameHeaderBytes + payload;
  }
  const int64_t found = static_cast<int64_t>(frames.size());
  const uint64_t tail = file_size - offset;  // bytes of a part frame
  std::string warning;
  if (found == 0 && (count > 0 || tail > 0))
    return error(ErrorCode::kCorruptData,
                 at(offset) + "truncated: the frame count says " + std::to_string(count) +
                     " frames and the file ends at byte " + std::to_string(file_size) + " before a whole one");
  if (found != count || tail > 0) {
    warning = "klg file '" + name + "' was cut while written: its frame count says " + std::to_string(count) + ", " +
              std::to_string(found) + " whole frame" + (found == 1 ? " is" : "s are") + " read";
    if (tail > 0) warning += ", and the last " + std::to_string(tail) + " bytes (a part frame) are left out";
  }

  SourceInfo info;
  info.uri = uri ? "klg:" + uri->path : "klg:" + name;
  info.intrinsics = Intrinsics{525.0f, 525.0f, 319.5f, 239.5f, 640, 480};
  if (side != nullptr) info.intrinsics = *side;
  if (width != info.intrinsics.width || height != info.intrinsics.height)
    info.intrinsics = info.intrinsics.scaled_to(width, height);
  if (uri) EF_RETURN_IF_ERROR(text::apply_intrinsics_overrides(*uri, info.intrinsics));
  // A .klg holds no calibration (ElasticFusion's format): its side file, the default, or the URI's.
  const std::string klg_default = "the default of a Kinect v1 (fx 525, cx 319.5 at 640x480; a .klg holds none)";
  const std::string from = side != nullptr ? klg_side_file(name) : klg_default;
  if (uri) text::describe_intrinsics(*uri, from, side == nullptr, &info.intrinsics_from, &info.intrinsics_assumed);
  else info.intrinsics_from = from, info.intrinsics_assumed = side == nullptr;
  info.frame_count = found;
  info.warning = warning;
  info.nominal_fps = 30;
  if (frames.size() > 1) {
    // In double: fuzzed timestamps span more than int64 can hold.
    const double span_us = double(frames.back().timestamp_us) - double(frames.front().timestamp_us);
    if (span_us > 0) info.nominal_fps = double(frames.size() - 1) * 1e6 / span_us;
  }
  info.has_pose = false;
  info.has_labels = false;
  info.has_color = any_color;
  return std::unique_ptr<FrameSource>(new KlgSource(std::move(info), name, std::move(input), std::move(frames)));
}

}  // namespace

Result<std::unique_ptr<FrameSource>> open_klg(const SourceUri& uri) {
  EF_RETURN_IF_ERROR(check_query_keys(uri, {"size", "fx", "fy", "cx", "cy"}));
  if (uri.path.empty()) return error(ErrorCode::kInvalidArgument, "klg: no file given (expected klg:FILE)");
  int width = 640, height = 480;
  // The side file `convert` writes: the recording's size and camera.
  std::optional<Intrinsics> side;
  std::error_code ec;
  if (std::filesystem::exists(klg_side_file(uri.path), ec)) {
    EF_ASSIGN_OR_RETURN(Intrinsics k, read_klg_side_file(klg_side_file(uri.path)));
    side = k;
    width = k.width;
    height = k.height;
  }
  if (auto it = uri.query.find("size"); it != uri.query.end()) {
    const std::string& v = it->second;
    const std::size_t x = v.find('x');
    int64_t w = 0, h = 0;
    if (x == std::string::npos || !text::parse_int(std::string_view(v).substr(0, x), 1, kMaxSide, w) ||
        !text::parse_int(std::string_view(v).substr(x + 1), 1, kMaxSide, h))
      return error(ErrorCode::kInvalidArgument, "klg file '" + uri.path + "': option size=" + v +
                                                    " is not WxH with 1..16384 pixels each (e.g. size=640x480)");
    width = int(w);
    height = int(h);
  }
  std::FILE* f = std::fopen(uri.path.c_str(), "rb");
  if (!f) {
    const int err = errno;
    return error(err == ENOENT ? ErrorCode::kNotFound : ErrorCode::kIoError,
                 "klg file '" + uri.path + "': cannot open (" + std::strerror(err) + ")");
  }
  off_t size = -1;
  if (fseeko(f, 0, SEEK_END) == 0) size = ftello(f);
  if (size < 0 || fseeko(f, 0, SEEK_SET) != 0) {
    std::fclose(f);
    return error(ErrorCode::kIoError, "klg file '" + uri.path + "': cannot determine its size (not a regular file?)");
  }
  return open_klg_input(std::make_unique<FileInput>(f, uint64_t(size)), uri.path, width, height, &uri,
                        side ? &*side : nullptr);
}

Result<std::unique_ptr<FrameSource>> open_klg_memory(const uint8_t* data, std::size_t size, int width, int height,
                                                     const std::string& name) {
  return open_klg_input(std::make_unique<MemoryInput>(data, size), name, width, height, nullptr, nullptr);
}

std::string klg_side_file(const std::string& klg_path) { return klg_path + ".intrinsics.txt"; }

Status write_klg_side_file(const std::string& klg_path, const Intrinsics& k) {
  char text[256];
  const int n = std::snprintf(text, sizeof text,
                              "# EdgeFusion: the size and camera of the .klg beside this file (pixels)\n"
                              "# width height fx fy cx cy\n%d %d %.9g %.9g %.9g %.9g\n",
                              k.width, k.height, double(k.fx), double(k.fy), double(k.cx), double(k.cy));
  return write_file_whole(klg_side_file(klg_path), {{text, static_cast<std::size_t>(n)}});
}

Result<Intrinsics> read_klg_side_file(const std::string& path) {
  std::string text;
  EF_RETURN_IF_ERROR(text::read_text_file(path, text));
  int line_no = 0;
  std::size_t at = 0;
  while (at <= text.size()) {
    const std::size_t end = std::min(text.find('\n', at), text.size());
    const std::string line = text.substr(at, end - at);
    at = end + 1;
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    Intrinsics k;
    char extra = 0;
    if (std::sscanf(line.c_str(), "%d %d %f %f %f %f %c", &k.width, &k.height, &k.fx, &k.fy, &k.cx, &k.cy, &extra) != 6 ||
        k.width < 1 || k.height < 1 || k.width > kMaxSide || k.height > kMaxSide || !(k.fx > 0) || !(k.fy > 0) ||
        !std::isfinite(k.cx) || !std::isfinite(k.cy))
      return error(ErrorCode::kCorruptData, path + ", line " + std::to_string(line_no) + ": '" + line +
                                                "' is not 'width height fx fy cx cy' (sizes 1.." +
                                                std::to_string(kMaxSide) + ", focal lengths > 0)");
    return k;
  }
  return error(ErrorCode::kCorruptData, path + ": no 'width height fx fy cx cy' line");
}

// ---------------------------------------------------------------------------------------------
// Writer

KlgWriter::~KlgWriter() {
  if (file_) (void)close();
}

Error KlgWriter::io_error(const std::string& what) const {
  return error(ErrorCode::kIoError, "klg file '" + path_ + "': " + what);
}

Status KlgWriter::open(const std::string& path, int width, int height, const KlgWriteOptions& options) {
  if (file_) return error(ErrorCode::kInvalidArgument, "klg writer: already open on '" + path_ + "'");
  if (width <= 0 || height <= 0 || width > kMaxSide || height > kMaxSide)
    return error(ErrorCode::kInvalidArgument, "klg file '" + path + "': size " + std::to_string(width) + "x" +
                                                  std::to_string(height) + " out of range");
  if (options.jpeg_quality < 0 || options.jpeg_quality > 100)
    return error(ErrorCode::kInvalidArgument, "klg file '" + path + "': JPEG quality " +
                                                  std::to_string(options.jpeg_quality) + " not in 0..100 (0 = raw)");
  path_ = path;
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_) return io_error(std::string("cannot create (") + std::strerror(errno) + ")");
  width_ = width;
  height_ = height;
  options_ = options;
  frames_ = 0;
  end_offset_ = 4;
  const std::size_t px = std::size_t(width) * std::size_t(height);
  depth_raw_.resize(px * 2);
  depth_zlib_.resize(compressBound(static_cast<uLong>(px * 2)));
  uint8_t count[4];
  store_le32(count, 0);  // patched after each frame
  if (std::fwrite(count, 1, 4, file_) != 4) return io_error("write failed");
  return Status();
}

Status KlgWriter::write(const Frame& frame) {
  if (!file_) return error(ErrorCode::kInvalidArgument, "klg writer: write() before open()");
  const auto bad = [&](const std::string& what) {
    return error(ErrorCode::kInvalidArgument,
                 "klg file '" + path_ + "', frame " + std::to_string(frames_) + ": " + what);
  };
  const std::string size_text = std::to_string(width_) + "x" + std::to_string(height_);
  if (frame.depth.width() != width_ || frame.depth.height() != height_)
    return bad("depth is " + std::to_string(frame.depth.width()) + "x" + std::to_string(frame.depth.height()) +
               ", the log is " + size_text);
  if (!frame.color.empty() && (frame.color.width() != width_ || frame.color.height() != height_))
    return bad("colour is " + std::to_string(frame.color.width()) + "x" + std::to_string(frame.color.height()) +
               ", the log is " + size_text);
  if (frames_ >= std::numeric_limits<int32_t>::max()) return bad("too many frames for a .klg");
  const double t_us = std::round(frame.timestamp * 1e6);
  if (!std::isfinite(t_us) || std::abs(t_us) > 9e18) return bad("timestamp out of range");

  // Depth: metres -> uint16 millimetres, little-endian.
  const std::size_t px = std::size_t(width_) * std::size_t(height_);
  const float* d = frame.depth.data();
  for (std::size_t i = 0; i < px; ++i) {
    const double mm = std::isfinite(d[i]) && d[i] > 0 ? std::round(double(d[i]) * 1000.0) : 0.0;
    const uint16_t v = mm <= 65535.0 ? uint16_t(mm) : 0;
    depth_raw_[2 * i] = uint8_t(v & 0xFF);
    depth_raw_[2 * i + 1] = uint8_t(v >> 8);
  }
  const uint8_t* depth_bytes = depth_raw_.data();
  std::size_t depth_size = px * 2;
  if (options_.compress_depth) {
    uLongf len = static_cast<uLongf>(depth_zlib_.size());
    if (compress2(depth_zlib_.data(), &len, depth_raw_.data(), static_cast<uLong>(px * 2), Z_BEST_SPEED) == Z_OK &&
        len < px * 2) {
      depth_bytes = depth_zlib_.data();
      depth_size = len;
    }
  }
  // Colour: none, raw, or JPEG (raw when the JPEG would not be smaller).
  const uint8_t* color_bytes = nullptr;
  std::size_t color_size = 0;
  if (!frame.color.empty()) {
    color_bytes = reinterpret_cast<const uint8_t*>(frame.color.data());
    color_size = px * 3;
    if (options_.jpeg_quality > 0) {
      EF_RETURN_IF_ERROR(encode_jpeg(frame.color.view(), options_.jpeg_quality, jpeg_));
      if (jpeg_.size() < px * 3) {
        color_bytes = reinterpret_cast<const uint8_t*>(jpeg_.data());
        color_size = jpeg_.size();
      }
    }
  }
  uint8_t hdr[kFrameHeaderBytes];
  store_le64(hdr, static_cast<int64_t>(t_us));
  store_le32(hdr + 8, static_cast<int32_t>(depth_size));
  store_le32(hdr + 12, static_cast<int32_t>(color_size));
  if (std::fwrite(hdr, 1, sizeof(hdr), file_) != sizeof(hdr) ||
      std::fwrite(depth_bytes, 1, depth_size, file_) != depth_size ||
      (color_size && std::fwrite(color_bytes, 1, color_size, file_) != color_size) || std::fflush(file_) != 0) {
    const int e = errno;
    // A part of the frame may have gone out: cut the file back to its whole frames.
    std::clearerr(file_);
    if (::ftruncate(fileno(file_), static_cast<off_t>(end_offset_)) == 0) fseeko(file_, static_cast<off_t>(end_offset_), SEEK_SET);
    return io_error("write failed at frame " + std::to_string(frames_) + ": " + std::strerror(e));
  }
  ++frames_;
  end_offset_ += sizeof(hdr) + depth_size + color_size;
  // The frame is in the file (flushed above) before the count says so: a recording killed at any
  // moment reads back with every whole frame (the reader also recovers one whose count lags).
  if (!patch_count()) return io_error("cannot update the frame count: " + std::string(std::strerror(errno)));
  return Status();
}

bool KlgWriter::patch_count() {
  uint8_t count[4];
  store_le32(count, static_cast<int32_t>(frames_));
  return ::pwrite(fileno(file_), count, 4, 0) == 4;
}

Status KlgWriter::close() {
  if (!file_) return Status();
  const bool ok = std::fflush(file_) == 0 && patch_count() && ::fsync(fileno(file_)) == 0;
  const int e = errno;
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!ok || !closed) return io_error(std::string("cannot finish the file: ") + std::strerror(e));
  return Status();
}

}  // namespace ef
