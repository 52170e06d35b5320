// libFuzzer target for the hand-written binary PPM (P6) reader of io/image_codec.cpp, which
// read_color_image() picks for a file starting "P6" (colour images of our own tools and tests).
// Input: the file's bytes, read from an in-memory file. Any crash, sanitizer report or hang is a
// bug; an error is the expected answer to a bad file.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.h"
#include "io/image_codec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static ef::fuzz::MemFile file;
  static ef::Image<ef::Rgb8> rgb;
  (void)ef::read_color_image(file.write(data, size), rgb);
  return 0;
}
