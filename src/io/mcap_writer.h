// MCAP field logs (issue 29; https://mcap.dev/spec, format version 0): our own writer.
//
// Layout written: magic, Header, then the data section: Schema and Channel records as they are
// added, and Chunk records (uncompressed) each followed by the MessageIndex records of its messages;
// a chunk is closed when it holds `chunk_seconds` of log time or `chunk_bytes`, so a file cut at any
// byte keeps every chunk before the cut (a reader streams records until the cut). close() writes
// DataEnd (with the data section's CRC-32), the summary section (Schemas, Channels, Statistics,
// ChunkIndexes), the SummaryOffsets, the Footer and the closing magic.
//
// Memory: the open chunk's bytes and its message index live in buffers sized at open() from
// chunk_bytes (a message larger than that gets a chunk of its own, the buffer growing for it);
// write() allocates nothing once the channels exist and every channel has had a chunk's worth of
// messages (its index entries keep their capacity); closing a chunk builds its index records (a
// few small allocations a chunk). Threads: one thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"

namespace ef {

struct McapWriterOptions {
  double chunk_seconds = 1.0;           // log time a chunk may span before it is closed, s
  std::size_t chunk_bytes = 4u << 20;   // bytes a chunk may hold before it is closed
  std::string profile = "ros2";         // the Header's profile ("ros2": ros2msg schemas, cdr messages)
  std::string library = "edgefusion";
  bool sync = false;  // fdatasync after each chunk, so a power cut loses at most the open chunk
};

class McapWriter {
 public:
  McapWriter() = default;
  ~McapWriter();  // closes (errors ignored: call close())
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  Status open(const std::string& path, const McapWriterOptions& options = {});
  // Returns the schema id (1, 2, ...). `encoding`: "ros2msg", "jsonschema", ...
  Result<uint16_t> add_schema(std::string_view name, std::string_view encoding, std::string_view data);
  // Returns the channel id (0, 1, ...).
  Result<uint16_t> add_channel(uint16_t schema_id, std::string_view topic, std::string_view message_encoding);
  // One message; log_time and publish_time in nanoseconds. Times should not go backwards per channel.
  Status write(uint16_t channel_id, uint64_t log_time_ns, uint64_t publish_time_ns, const void* data,
               std::size_t bytes);
  // A message too large to hold in memory (a map snapshot): the open chunk is closed, and the message
  // goes straight to the file as a chunk of its own, its `bytes` of data given in pieces by
  // `produce`, which calls `put(data, n)` until they are all written. That chunk's CRC is 0 ("not
  // computed": the spec's value for a writer that streams); the data section's CRC covers it.
  // Errors: produce's, the file's, a produced size that differs from `bytes`.
  using Put = std::function<Status(const void* data, std::size_t n)>;
  Status write_streamed(uint16_t channel_id, uint64_t log_time_ns, uint64_t bytes,
                        const std::function<Status(const Put& put)>& produce);
  // Closes the open chunk now (a checkpoint of the log: everything so far is readable after a cut).
  Status flush();
  Status close();
  // Closes the file after a failed write (a full disk) without writing anything more: what it
  // holds stays a log cut after its last whole chunk (readers read up to it).
  void abandon();

  uint64_t messages() const { return message_count_; }
  bool is_open() const { return file_ != nullptr; }

 private:
  struct Schema {
    uint16_t id;
    std::string name, encoding, data;
  };
  struct Channel {
    uint16_t id, schema_id;
    std::string topic, encoding;
    uint64_t messages = 0;
    uint32_t sequence = 0;
  };
  struct ChunkIndex {
    uint64_t start_time, end_time, offset, length, index_offset, index_length, size;
    std::vector<std::pair<uint16_t, uint64_t>> index_offsets;  // channel -> MessageIndex offset
  };
  Status put(const void* data, std::size_t bytes);  // to the file, into the data CRC
  Status close_chunk();
  Status to_disk();  // flush, and fdatasync with options_.sync
  void count_message(Channel& ch, uint64_t log_time_ns);  // the statistics' counts and times
  void record(std::string& out, uint8_t opcode, const std::string& body) const;

  std::FILE* file_ = nullptr;
  std::string path_;
  McapWriterOptions options_;
  uint64_t offset_ = 0;       // bytes written
  uint32_t data_crc_ = 0;     // CRC-32 of the data section so far
  std::vector<Schema> schemas_;
  std::vector<Channel> channels_;
  std::vector<ChunkIndex> chunks_;
  // The open chunk: its records, and per channel (log_time, offset in the chunk) pairs.
  std::string chunk_;
  std::vector<std::vector<std::pair<uint64_t, uint64_t>>> chunk_index_;
  uint64_t chunk_start_ = 0, chunk_end_ = 0;
  bool chunk_empty_ = true;
  uint64_t message_count_ = 0, first_time_ = 0, last_time_ = 0;
};

}  // namespace ef
