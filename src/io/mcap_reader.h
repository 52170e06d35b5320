// MCAP field logs (https://mcap.dev/spec, format version 0): our own reader, for replaying our logs
// (io/mcap_source.h) and for the tests. It reads the data section from the start, record by record,
// so a log cut at any byte (a kill, a power cut, a full disk) is read up to its last whole record;
// the summary at the end is not needed and not read. What it reads: Header, Schema, Channel and
// Message records, in the data section and inside Chunks (uncompressed chunks only: our writer
// compresses the images, not the chunks; a zstd or lz4 chunk is an error naming it).
//
// Decisions:
//   * A record whose length runs past the end of the file, or a chunk whose CRC does not match its
//     bytes (a cut while the page was written), ends the reading there: not an error but warning(),
//     which names the byte offset and what was left out. The messages before it are all there.
//   * A malformed record inside the whole part (a length that does not fit its record, a message on
//     a channel never defined, a channel on a schema never defined) is an error naming its offset.
//   * Messages are listed in file order with their file offsets; their bytes are read on demand.
//
// Memory: the schema and channel tables and 32 bytes per message (kept for the whole file).
// Threads: one thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/result.h"

namespace ef {

struct McapSchema {
  uint16_t id = 0;
  std::string name, encoding, data;
};

struct McapChannel {
  uint16_t id = 0, schema_id = 0;
  std::string topic, message_encoding;
  uint64_t messages = 0;  // found in the readable part
};

struct McapMessageRef {
  uint64_t log_time = 0, publish_time = 0;  // ns
  uint64_t offset = 0;                       // of the message's data in the file
  uint32_t bytes = 0;                        // of its data
  uint32_t sequence = 0;
  uint16_t channel = 0;
};

class McapReader {
 public:
  McapReader() = default;
  ~McapReader();
  McapReader(const McapReader&) = delete;
  McapReader& operator=(const McapReader&) = delete;

  // Reads the file's records (see above). Errors: the file, not an MCAP file, a malformed record.
  Status open(const std::string& path);
  // The same over bytes in memory (tests, fuzzing); `data` must outlive the reader.
  Status open_memory(const uint8_t* data, std::size_t size, const std::string& name);

  const std::string& profile() const { return profile_; }
  const std::string& library() const { return library_; }
  const std::vector<McapSchema>& schemas() const { return schemas_; }
  const std::vector<McapChannel>& channels() const { return channels_; }
  const std::vector<McapMessageRef>& messages() const { return messages_; }
  // The channel named `topic`, or nullptr.
  const McapChannel* channel(const std::string& topic) const;
  const McapSchema* schema(uint16_t id) const;
  // Empty when the data section ended properly (DataEnd); otherwise what was left out and why.
  const std::string& warning() const { return warning_; }
  bool complete() const { return warning_.empty(); }
  uint64_t chunks() const { return chunks_; }

  // A message's data into `out` (reused). Errors: a read that fails.
  Status read(const McapMessageRef& message, std::string& out) const;
  const std::string& name() const { return name_; }

 private:
  Status walk();
  bool read_at(uint64_t offset, void* dst, std::size_t bytes) const;
  Status parse_records(const uint8_t* p, std::size_t n, uint64_t base, bool in_chunk);
  Error corrupt(uint64_t offset, const std::string& what) const;

  std::string name_;
  int fd_ = -1;
  const uint8_t* memory_ = nullptr;
  uint64_t size_ = 0;
  std::string profile_, library_, warning_;
  std::vector<McapSchema> schemas_;
  std::vector<McapChannel> channels_;
  std::vector<McapMessageRef> messages_;
  uint64_t chunks_ = 0;
  std::string scratch_;
};

}  // namespace ef
