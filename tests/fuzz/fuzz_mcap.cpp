// libFuzzer target for the field log reader (io/mcap_reader.h) and the mcap: source that replays it
// (io/mcap_source.h): MCAP records, chunks, CDR messages of Foxglove's types, the PNG and JPEG
// images inside them. Input: the file's bytes. A log the reader accepts has every message read back,
// and the source's first frames decoded; any crash, sanitizer report or hang is a bug. (Chunk CRCs
// stop most mutations inside chunks; a CRC of 0 means "not computed", which the fuzzer finds.)
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/frame.h"
#include "io/mcap_reader.h"
#include "io/mcap_source.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ef::McapReader reader;
  if (reader.open_memory(data, size, "fuzz.mcap").ok()) {
    std::string buf;
    for (const ef::McapMessageRef& m : reader.messages()) (void)reader.read(m, buf);
  }
  auto source = ef::open_mcap_memory(data, size, "fuzz.mcap");
  if (!source.ok()) return 0;
  ef::Frame frame;
  for (int i = 0; i < 4; ++i) {
    auto got = (*source)->next(frame);
    if (!got.ok() || !*got) break;
  }
  return 0;
}
