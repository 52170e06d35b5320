// libFuzzer target for the field log reader (io/mcap_reader.h) and the mcap: source that replays it
// (io/mcap_source.h): MCAP records, chunks, CDR messages of Foxglove's types, the PNG and JPEG
// images inside them. Input: the file's bytes, read as given and then with the checksums made right
// (a structure-aware fix up: the PNGs' chunk CRCs inside the messages, then each Chunk record's CRC
// over its records), so that mutations inside a chunk reach the messages instead of stopping at a
// CRC. A log the reader accepts has every message read back, and the source's first frames decoded;
// any crash, sanitizer report or hang is a bug; an error is the expected answer to a bad file.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/frame.h"
#include "fuzz_support.h"
#include "io/mcap_reader.h"
#include "io/mcap_source.h"

namespace {

uint64_t get_le64(const uint8_t* p) {
  return uint64_t(ef::fuzz::get_le32(p)) | uint64_t(ef::fuzz::get_le32(p + 4)) << 32;
}

// Top-level records after the 8-byte magic: opcode (1), length (u64), body. A Chunk (0x06) body is
// start, end, uncompressed size (u64 each), CRC (u32), compression (u32 length + text), records
// length (u64), records. Returns whether a byte changed.
bool fix_mcap_crcs(std::vector<uint8_t>& b) {
  bool changed = false;
  std::size_t pos = 8;
  while (b.size() >= 9 && pos <= b.size() - 9) {
    const uint8_t op = b[pos];
    const uint64_t len = get_le64(&b[pos + 1]);
    const std::size_t body = pos + 9;
    if (len > b.size() - body) break;
    if (op == 0x06 && len >= 24 + 4 + 4) {
      const uint64_t text = ef::fuzz::get_le32(&b[body + 28]);
      const uint64_t head = 24 + 4 + 4 + text + 8;
      if (text <= len && head <= len) {
        uint8_t* records = &b[body + head];
        const std::size_t n = static_cast<std::size_t>(len - head);
        changed = ef::fuzz::fix_embedded_png_crcs(records, n) || changed;
        const uint32_t crc = ef::fuzz::crc32_of(records, n);
        if (ef::fuzz::get_le32(&b[body + 24]) != crc) {
          ef::fuzz::put_le32(&b[body + 24], crc);
          changed = true;
        }
      }
    }
    pos = body + static_cast<std::size_t>(len);
  }
  return changed;
}

void read_log(const uint8_t* data, std::size_t size) {
  ef::McapReader reader;
  if (reader.open_memory(data, size, "fuzz.mcap").ok()) {
    std::string buf;
    for (const ef::McapMessageRef& m : reader.messages()) (void)reader.read(m, buf);
  }
  auto source = ef::open_mcap_memory(data, size, "fuzz.mcap");
  if (!source.ok()) return;
  ef::Frame frame;
  for (int i = 0; i < 4; ++i) {
    auto got = (*source)->next(frame);
    if (!got.ok() || !*got) break;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  read_log(data, size);
  std::vector<uint8_t> fixed(data, data + size);
  if (fix_mcap_crcs(fixed)) read_log(fixed.data(), fixed.size());
  return 0;
}
