// Map snapshots (checkpoints): a versioned container of checksummed sections (docs/snapshot_format.md).
//
//   header   16 bytes: magic "EFSNAP\r\n" (8), format version u32 (1), reserved u32 (0)
//   section  16-byte header: tag (4 ASCII bytes), payload bytes u64, CRC-32 of the payload u32;
//            then the payload, zero-padded to a multiple of 8 bytes
//   end      a last section tagged "END " whose payload is the CRC-32 of every byte before it
// Little-endian throughout. Sections appear in the order written; readers look them up by tag.
//
// The writer streams (no copy of a payload is made: the surfel pool's columns go straight to the
// file) into FileReplacement's .partial (io/durable_file.h), so a snapshot is whole or absent. The
// reader checks everything before it hands out a byte: magic, version, section bounds, each CRC and
// the end marker; each fault is an error naming the file, the section and the byte offset.
//
// Threads: an object belongs to one thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "core/result.h"
#include "io/durable_file.h"

namespace ef {

inline constexpr uint32_t kSnapshotVersion = 1;

class SnapshotWriter {
 public:
  // Starts <path>.partial. Errors name the file.
  Status open(const std::string& path);
  // A section whose payload is the concatenation of `parts` (pointer, bytes). Allocates nothing.
  struct Part {
    const void* data;
    std::size_t bytes;
  };
  Status section(const char tag[4], const Part* parts, std::size_t count);
  Status section(const char tag[4], const void* data, std::size_t bytes) {
    const Part p{data, bytes};
    return section(tag, &p, 1);
  }
  // Writes the end marker, syncs and renames the file into place (FileReplacement::commit()).
  // With `previous_path`, an existing <path> first becomes that file (one rename each, so a crash
  // between them leaves the previous snapshot, never none).
  Status commit(const std::string& previous_path = {});
  ~SnapshotWriter();

 private:
  Status put(const void* data, std::size_t bytes);
  std::FILE* file_ = nullptr;
  std::unique_ptr<FileReplacement> replacement_;
  std::string path_;
  uint32_t sections_ = 0;
  uint32_t file_crc_ = 0;
  uint64_t offset_ = 0;
};

class SnapshotReader {
 public:
  // Opens and checks the whole file (every CRC, the end marker). Errors (kCorruptData, kNotFound,
  // kUnsupported for a newer version) name the file and what is wrong where.
  Status open(const std::string& path);
  ~SnapshotReader();

  bool has(const char tag[4]) const;
  // Payload bytes of a section (0 when absent).
  uint64_t size(const char tag[4]) const;
  // Reads `bytes` of section `tag` from `offset` within it into `dst`. Errors: no such section, a
  // range past its end, a failed read.
  Status read(const char tag[4], void* dst, std::size_t bytes, uint64_t offset = 0) const;
  const std::string& path() const { return path_; }

 private:
  struct Entry {
    char tag[4];
    uint64_t offset;  // of the payload in the file
    uint64_t bytes;
  };
  const Entry* find(const char tag[4]) const;
  std::FILE* file_ = nullptr;
  std::string path_;
  std::vector<Entry> entries_;
};

}  // namespace ef
