// libFuzzer target for the .klg reader. Input: byte 0 and 1 choose the resolution (1..32 each, so
// raw frames are reachable), the rest is the .klg file. Every frame is read until the end or the
// first error; any crash, sanitizer report or hang is a bug.
#include <cstddef>
#include <cstdint>

#include "io/klg_format.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  const int width = 1 + data[0] % 32;
  const int height = 1 + data[1] % 32;
  auto src = ef::open_klg_memory(data + 2, size - 2, width, height, "fuzz.klg");
  if (!src.ok()) return 0;
  ef::Frame frame;
  for (int i = 0; i < 256; ++i) {
    auto r = (*src)->next(frame);
    if (!r.ok() || !*r) break;
  }
  return 0;
}
