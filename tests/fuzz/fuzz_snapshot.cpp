// libFuzzer target for the map snapshot reader (io/snapshot_file.h: checkpoint.efs, which `run
// --resume` and `export` read). Input: the file's bytes, written to a scratch file (the reader takes
// a path). A file the reader accepts has every section read back whole; any crash, sanitizer report
// or hang is a bug.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <unistd.h>

#include "io/snapshot_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = "/tmp/fuzz_snapshot." + std::to_string(::getpid()) + ".efs";
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return 0;
  const bool wrote = size == 0 || std::fwrite(data, 1, size, f) == size;
  std::fclose(f);
  if (!wrote) return 0;
  ef::SnapshotReader r;
  if (!r.open(path).ok()) return 0;
  // The checkpoint's sections, each read whole (bounded: the file itself bounds them).
  static const char kTags[][4] = {{'M', 'E', 'T', 'A'}, {'S', 'L', 'A', 'M'}, {'P', 'O', 'O', 'L'},
                                  {'C', 'N', 'T', 'N'}, {'C', 'N', 'T', 'V'}};
  for (const auto& tag : kTags) {
    if (!r.has(tag)) continue;
    std::vector<unsigned char> bytes(static_cast<std::size_t>(r.size(tag)));
    (void)r.read(tag, bytes.data(), bytes.size());
    (void)r.read(tag, bytes.data(), 1, r.size(tag));  // past the end: an error, never a read
  }
  return 0;
}
