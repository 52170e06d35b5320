// A PNG encoder that allocates nothing per image (issue 29's field logs encode a depth image per
// frame on the pipeline's threads): 8-bit gray, 16-bit gray and 8-bit RGB, no interlace, each row
// with the "Up" filter (depth and colour change little from row to row, so the differences deflate
// well), one IDAT chunk. libpng (io/image_codec.h) creates and frees its state for every image; this
// encoder keeps one zlib stream and its buffers, sized for the largest image at construction, and
// resets them per image. Decoding stays with libpng (decode_png_* in io/image_codec.h).
//
// Threads: one encoder per thread. Memory: bytes_for(max_width, max_height, 2 or 3) plus zlib's
// state (about 256 kB at the default window) allocated by the constructor.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/result.h"

struct z_stream_s;

namespace ef {

class PngEncoder {
 public:
  // level: zlib's 1 (fastest) .. 9 (smallest). Images up to max_width x max_height with up to
  // `max_channel_bytes` bytes per pixel (2: 16-bit gray, 3: RGB) encode without allocating.
  PngEncoder(int max_width, int max_height, int max_pixel_bytes = 3, int level = 1);
  ~PngEncoder();
  PngEncoder(const PngEncoder&) = delete;
  PngEncoder& operator=(const PngEncoder&) = delete;

  // The whole PNG file into `out` (replaced; its capacity is kept, so pass the same string each time).
  // Errors: an empty image, zlib's failure.
  Status encode(ImageView<const uint16_t> image, std::string& out);
  Status encode(ImageView<const uint8_t> image, std::string& out);
  Status encode(ImageView<const Rgb8> image, std::string& out);

  // Bytes of the output a max-size image may need (what `out` is reserved to).
  static std::size_t bytes_for(int width, int height, int pixel_bytes);

 private:
  Status encode_rows(const uint8_t* base, std::size_t stride, int width, int height, int pixel_bytes,
                     int bit_depth, int color_type, std::string& out);
  z_stream_s* z_ = nullptr;
  bool z_ok_ = false;
  std::size_t max_pixels_bytes_ = 0;
  std::vector<uint8_t> row_, filtered_;  // one row as PNG samples (big-endian), its filtered form
};

}  // namespace ef
