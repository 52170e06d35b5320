// libFuzzer target for PNG images through io/image_codec.h (libpng behind our reader): the field
// log's depth, colour and label images from memory, and TUM / 7-Scenes depth, colour and label files
// from a path. Input: byte 0 picks the reader, the rest is the PNG.
//   0 decode_png_u16   1 decode_png_u8   2 decode_png_rgb        (memory)
//   3 read_png_u16     4 read_png_u8     5 read_color_image      (a file: an in-memory one)
// Each input is read as given, then with every chunk's CRC fixed (libpng refuses a chunk whose CRC
// is wrong, so without it mutations stop at the first chunk they touch). Any crash, sanitizer report
// or hang is a bug; an error is the expected answer to a bad file.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fuzz_support.h"
#include "io/image_codec.h"

namespace {

void read_with(int reader, const uint8_t* data, std::size_t size) {
  static ef::fuzz::MemFile file;
  static ef::Image<uint16_t> u16;
  static ef::Image<uint8_t> u8;
  static ef::Image<ef::Rgb8> rgb;
  switch (reader) {
    case 0: (void)ef::decode_png_u16(data, size, u16, "fuzz.png"); break;
    case 1: (void)ef::decode_png_u8(data, size, u8, "fuzz.png"); break;
    case 2: (void)ef::decode_png_rgb(data, size, rgb, "fuzz.png"); break;
    case 3: (void)ef::read_png_u16(file.write(data, size), u16); break;
    case 4: (void)ef::read_png_u8(file.write(data, size), u8); break;
    default: (void)ef::read_color_image(file.write(data, size), rgb); break;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const int reader = data[0] % 6;
  read_with(reader, data + 1, size - 1);
  std::vector<uint8_t> fixed(data + 1, data + size);
  if (ef::fuzz::fix_png_crcs(fixed)) read_with(reader, fixed.data(), fixed.size());
  return 0;
}
