// libFuzzer target for JPEG images through io/image_codec.h (libjpeg-turbo behind our decoder): the
// colour of .klg frames and field logs from memory, and colour files (TUM, 7-Scenes) from a path.
// Input: byte 0 picks the reader (even: decode_jpeg from memory; odd: read_color_image of a file,
// an in-memory one), the rest is the JPEG. JPEG has no checksum to fix. Any crash, sanitizer report
// or hang is a bug; an error is the expected answer to a bad file.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.h"
#include "io/image_codec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static ef::fuzz::MemFile file;
  static ef::Image<ef::Rgb8> rgb;
  if (data[0] % 2 == 0)
    (void)ef::decode_jpeg(data + 1, size - 1, rgb, "fuzz.jpg");
  else
    (void)ef::read_color_image(file.write(data + 1, size - 1), rgb);
  return 0;
}
