#include "io/png_encoder.h"

#include <cstring>

#include <zlib.h>

namespace ef {

namespace {

constexpr unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};

void put_be32(std::string& s, std::size_t at, uint32_t v) {
  s[at] = static_cast<char>(v >> 24);
  s[at + 1] = static_cast<char>(v >> 16);
  s[at + 2] = static_cast<char>(v >> 8);
  s[at + 3] = static_cast<char>(v);
}

void append_be32(std::string& s, uint32_t v) {
  s.resize(s.size() + 4);
  put_be32(s, s.size() - 4, v);
}

// A chunk whose type and data are already in `s` from `type_at` on: the length before them was
// reserved; the CRC (over type and data) is appended.
void finish_chunk(std::string& s, std::size_t type_at) {
  const std::size_t data_bytes = s.size() - type_at - 4;
  put_be32(s, type_at - 4, static_cast<uint32_t>(data_bytes));
  const uLong c = ::crc32(0, reinterpret_cast<const Bytef*>(s.data() + type_at), static_cast<uInt>(data_bytes + 4));
  append_be32(s, static_cast<uint32_t>(c));
}

std::size_t begin_chunk(std::string& s, const char type[4]) {
  s.append(4, '\0');  // length, patched by finish_chunk
  const std::size_t at = s.size();
  s.append(type, 4);
  return at;
}

}  // namespace

std::size_t PngEncoder::bytes_for(int width, int height, int pixel_bytes) {
  const uLong filtered = static_cast<uLong>(height) * (1 + static_cast<uLong>(width) * pixel_bytes);
  // Signature, IHDR (25), IDAT's framing (12), IEND (12), and deflate's worst case (stored blocks).
  return 8 + 25 + 12 + 12 + ::compressBound(filtered) + 64;
}

PngEncoder::PngEncoder(int max_width, int max_height, int max_pixel_bytes, int level) {
  max_pixels_bytes_ = static_cast<std::size_t>(max_width) * max_height * max_pixel_bytes;
  row_.resize(static_cast<std::size_t>(max_width) * max_pixel_bytes);
  filtered_.resize(row_.size() + 1);
  z_ = new z_stream_s{};
  z_ok_ = ::deflateInit(z_, level < 1 ? 1 : (level > 9 ? 9 : level)) == Z_OK;
}

PngEncoder::~PngEncoder() {
  if (z_ok_) ::deflateEnd(z_);
  delete z_;
}

Status PngEncoder::encode_rows(const uint8_t* base, std::size_t stride, int width, int height, int pixel_bytes,
                               int bit_depth, int color_type, std::string& out) {
  if (width <= 0 || height <= 0) return error(ErrorCode::kInvalidArgument, "PNG encode: empty image");
  if (!z_ok_) return error(ErrorCode::kResourceExhausted, "PNG encode: zlib could not be initialised");
  const std::size_t row_bytes = static_cast<std::size_t>(width) * pixel_bytes;
  if (row_bytes * height > max_pixels_bytes_ || row_bytes > row_.size())
    return error(ErrorCode::kInvalidArgument, "PNG encode: a " + std::to_string(width) + "x" + std::to_string(height) +
                                                  " image is larger than the encoder was sized for");
  out.clear();
  // Grown once to the largest image's bound; never asked to shrink (before C++20, reserve() with a
  // smaller size may reallocate to shrink).
  const std::size_t need = bytes_for(width, height, pixel_bytes);
  if (out.capacity() < need) out.reserve(need);
  out.append(reinterpret_cast<const char*>(kSignature), sizeof kSignature);
  std::size_t type_at = begin_chunk(out, "IHDR");
  append_be32(out, static_cast<uint32_t>(width));
  append_be32(out, static_cast<uint32_t>(height));
  out.push_back(static_cast<char>(bit_depth));
  out.push_back(static_cast<char>(color_type));
  out.append(3, '\0');  // deflate, adaptive filtering, no interlace
  finish_chunk(out, type_at);

  type_at = begin_chunk(out, "IDAT");
  // deflate writes straight into `out` past the chunk type, within the capacity reserved above.
  const std::size_t z_start = out.size();
  out.resize(out.capacity() - 16);  // 12 bytes of IEND and the CRC stay free
  if (::deflateReset(z_) != Z_OK) return error(ErrorCode::kInternal, "PNG encode: deflateReset failed");
  z_->next_out = reinterpret_cast<Bytef*>(&out[z_start]);
  z_->avail_out = static_cast<uInt>(out.size() - z_start);
  const bool swap16 = bit_depth == 16;
  std::memset(row_.data(), 0, row_bytes);  // the row above the first is zeros
  for (int y = 0; y < height; ++y) {
    const uint8_t* src = base + static_cast<std::size_t>(y) * stride;
    filtered_[0] = 2;  // Up: each byte minus the byte above it
    for (std::size_t i = 0; i < row_bytes; i += (swap16 ? 2 : 1)) {
      if (swap16) {  // samples are big-endian in PNG; ours are in host order (little-endian)
        uint16_t v;
        std::memcpy(&v, src + i, 2);
        const uint8_t hi = static_cast<uint8_t>(v >> 8), lo = static_cast<uint8_t>(v);
        filtered_[1 + i] = static_cast<uint8_t>(hi - row_[i]);
        filtered_[2 + i] = static_cast<uint8_t>(lo - row_[i + 1]);
        row_[i] = hi;
        row_[i + 1] = lo;
      } else {
        filtered_[1 + i] = static_cast<uint8_t>(src[i] - row_[i]);
        row_[i] = src[i];
      }
    }
    z_->next_in = filtered_.data();
    z_->avail_in = static_cast<uInt>(row_bytes + 1);
    const int flush = y + 1 == height ? Z_FINISH : Z_NO_FLUSH;
    const int r = ::deflate(z_, flush);
    if (r == Z_STREAM_ERROR || z_->avail_in != 0 || (flush == Z_FINISH && r != Z_STREAM_END))
      return error(ErrorCode::kInternal, "PNG encode: deflate failed (output bound exceeded)");
  }
  out.resize(z_start + z_->total_out);
  finish_chunk(out, type_at);
  type_at = begin_chunk(out, "IEND");
  finish_chunk(out, type_at);
  return Status::success();
}

Status PngEncoder::encode(ImageView<const uint16_t> image, std::string& out) {
  const uint16_t probe = 1;
  uint8_t first = 0;
  std::memcpy(&first, &probe, 1);
  if (first != 1) return error(ErrorCode::kUnsupported, "PNG encode: 16-bit samples need a little-endian host");
  return encode_rows(reinterpret_cast<const uint8_t*>(image.data), image.stride_bytes, image.width,
                     image.height, 2, 16, 0, out);
}

Status PngEncoder::encode(ImageView<const uint8_t> image, std::string& out) {
  return encode_rows(image.data, image.stride_bytes, image.width, image.height, 1, 8, 0, out);
}

Status PngEncoder::encode(ImageView<const Rgb8> image, std::string& out) {
  return encode_rows(reinterpret_cast<const uint8_t*>(image.data), image.stride_bytes, image.width,
                     image.height, 3, 8, 2, out);
}

}  // namespace ef
