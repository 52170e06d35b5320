#include "io/mcap_writer.h"

#include <cerrno>
#include <cstring>

#include <stdio_ext.h>
#include <unistd.h>
#include <zlib.h>

namespace ef {

namespace {

constexpr unsigned char kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
enum Op : uint8_t {
  kHeader = 0x01, kFooter = 0x02, kSchema = 0x03, kChannel = 0x04, kMessage = 0x05, kChunk = 0x06,
  kMessageIndex = 0x07, kChunkIndex = 0x08, kStatistics = 0x0B, kSummaryOffset = 0x0E, kDataEnd = 0x0F,
};

// Little-endian appenders (the spec's primitive types).
void u8(std::string& s, uint8_t v) { s.push_back(static_cast<char>(v)); }
void u16(std::string& s, uint16_t v) {
  for (int i = 0; i < 2; ++i) s.push_back(static_cast<char>(v >> (8 * i)));
}
void u32(std::string& s, uint32_t v) {
  for (int i = 0; i < 4; ++i) s.push_back(static_cast<char>(v >> (8 * i)));
}
void u64(std::string& s, uint64_t v) {
  for (int i = 0; i < 8; ++i) s.push_back(static_cast<char>(v >> (8 * i)));
}
void str(std::string& s, std::string_view v) {
  u32(s, static_cast<uint32_t>(v.size()));
  s.append(v.data(), v.size());
}

uint32_t crc(uint32_t c, const void* data, std::size_t bytes) {
  return static_cast<uint32_t>(::crc32(c, static_cast<const Bytef*>(data), static_cast<uInt>(bytes)));
}

}  // namespace

McapWriter::~McapWriter() { (void)close(); }

void McapWriter::record(std::string& out, uint8_t opcode, const std::string& body) const {
  u8(out, opcode);
  u64(out, body.size());
  out += body;
}

Status McapWriter::put(const void* data, std::size_t bytes) {
  if (bytes > 0 && std::fwrite(data, 1, bytes, file_) != bytes)
    return error(ErrorCode::kIoError, path_ + ": write failed at byte " + std::to_string(offset_) + ": " +
                                          std::strerror(errno));
  data_crc_ = crc(data_crc_, data, bytes);
  offset_ += bytes;
  return Status::success();
}

Status McapWriter::open(const std::string& path, const McapWriterOptions& options) {
  if (file_ != nullptr) return error(ErrorCode::kInvalidArgument, "mcap writer: already open on '" + path_ + "'");
  path_ = path;
  options_ = options;
  file_ = std::fopen(path.c_str(), "wb");
  if (file_ == nullptr) return error(ErrorCode::kIoError, path + ": cannot create: " + std::strerror(errno));
  offset_ = 0;
  data_crc_ = 0;
  schemas_.clear();
  channels_.clear();
  chunks_.clear();
  chunk_.clear();
  chunk_.reserve(options.chunk_bytes + 4096);
  chunk_index_.clear();
  chunk_empty_ = true;
  message_count_ = 0;
  EF_RETURN_IF_ERROR(put(kMagic, sizeof kMagic));
  std::string body, rec;
  str(body, options.profile);
  str(body, options.library);
  record(rec, kHeader, body);
  return put(rec.data(), rec.size());
}

Result<uint16_t> McapWriter::add_schema(std::string_view name, std::string_view encoding, std::string_view data) {
  if (file_ == nullptr) return error(ErrorCode::kInvalidArgument, "mcap writer: add_schema() before open()");
  const uint16_t id = static_cast<uint16_t>(schemas_.size() + 1);  // 0 means "no schema"
  schemas_.push_back({id, std::string(name), std::string(encoding), std::string(data)});
  std::string body, rec;
  u16(body, id);
  str(body, name);
  str(body, encoding);
  str(body, data);
  record(rec, kSchema, body);
  EF_RETURN_IF_ERROR(put(rec.data(), rec.size()));
  return id;
}

Result<uint16_t> McapWriter::add_channel(uint16_t schema_id, std::string_view topic, std::string_view encoding) {
  if (file_ == nullptr) return error(ErrorCode::kInvalidArgument, "mcap writer: add_channel() before open()");
  if (schema_id == 0 || schema_id > schemas_.size())
    return error(ErrorCode::kInvalidArgument, path_ + ": channel '" + std::string(topic) + "': no schema " +
                                                  std::to_string(schema_id));
  const uint16_t id = static_cast<uint16_t>(channels_.size());
  channels_.push_back({id, schema_id, std::string(topic), std::string(encoding)});
  chunk_index_.emplace_back();
  std::string body, rec;
  u16(body, id);
  u16(body, schema_id);
  str(body, topic);
  str(body, encoding);
  u32(body, 0);  // metadata: an empty map
  record(rec, kChannel, body);
  EF_RETURN_IF_ERROR(put(rec.data(), rec.size()));
  return id;
}

Status McapWriter::write(uint16_t channel_id, uint64_t log_time_ns, uint64_t publish_time_ns, const void* data,
                         std::size_t bytes) {
  if (file_ == nullptr) return error(ErrorCode::kInvalidArgument, "mcap writer: write() before open()");
  if (channel_id >= channels_.size())
    return error(ErrorCode::kInvalidArgument, path_ + ": no channel " + std::to_string(channel_id));
  // Close the open chunk first when this message would take it past its time span or size.
  if (!chunk_empty_ && (static_cast<double>(log_time_ns - std::min(log_time_ns, chunk_start_)) >
                            options_.chunk_seconds * 1e9 ||
                        chunk_.size() + bytes + 31 > options_.chunk_bytes))
    EF_RETURN_IF_ERROR(close_chunk());
  Channel& ch = channels_[channel_id];
  if (chunk_empty_) {
    chunk_start_ = chunk_end_ = log_time_ns;
    chunk_empty_ = false;
  }
  chunk_start_ = std::min(chunk_start_, log_time_ns);
  chunk_end_ = std::max(chunk_end_, log_time_ns);
  chunk_index_[channel_id].emplace_back(log_time_ns, chunk_.size());
  u8(chunk_, kMessage);
  u64(chunk_, 2 + 4 + 8 + 8 + bytes);
  u16(chunk_, channel_id);
  u32(chunk_, ch.sequence++);
  u64(chunk_, log_time_ns);
  u64(chunk_, publish_time_ns);
  chunk_.append(static_cast<const char*>(data), bytes);
  count_message(ch, log_time_ns);
  return Status::success();
}

Status McapWriter::close_chunk() {
  if (chunk_empty_) return Status::success();
  ChunkIndex index{};
  index.start_time = chunk_start_;
  index.end_time = chunk_end_;
  index.offset = offset_;
  index.size = chunk_.size();
  std::string head;
  u8(head, kChunk);
  const uint64_t body_bytes = 8 + 8 + 8 + 4 + 4 + 8 + chunk_.size();
  u64(head, body_bytes);
  u64(head, chunk_start_);
  u64(head, chunk_end_);
  u64(head, chunk_.size());
  u32(head, crc(0, chunk_.data(), chunk_.size()));
  str(head, "");  // no compression: the images in it are compressed already
  u64(head, chunk_.size());
  EF_RETURN_IF_ERROR(put(head.data(), head.size()));
  EF_RETURN_IF_ERROR(put(chunk_.data(), chunk_.size()));
  index.length = head.size() + chunk_.size();
  // Its message indexes, one record per channel with messages in it.
  index.index_offset = offset_;
  for (uint16_t c = 0; c < chunk_index_.size(); ++c) {
    auto& entries = chunk_index_[c];
    if (entries.empty()) continue;
    index.index_offsets.emplace_back(c, offset_);
    std::string body, rec;
    u16(body, c);
    u32(body, static_cast<uint32_t>(entries.size() * 16));
    for (const auto& [t, off] : entries) {
      u64(body, t);
      u64(body, off);
    }
    record(rec, kMessageIndex, body);
    EF_RETURN_IF_ERROR(put(rec.data(), rec.size()));
    entries.clear();
  }
  index.index_length = offset_ - index.index_offset;
  chunks_.push_back(std::move(index));
  chunk_.clear();
  chunk_empty_ = true;
  return to_disk();
}

Status McapWriter::to_disk() {
  // What is written so far reaches the disk with the chunk: a cut keeps it.
  if (std::fflush(file_) != 0) return error(ErrorCode::kIoError, path_ + ": flush failed: " + std::strerror(errno));
  if (options_.sync && ::fdatasync(::fileno(file_)) != 0)
    return error(ErrorCode::kIoError, path_ + ": sync failed: " + std::strerror(errno));
  return Status::success();
}

void McapWriter::count_message(Channel& ch, uint64_t log_time_ns) {
  if (message_count_ == 0) first_time_ = last_time_ = log_time_ns;
  first_time_ = std::min(first_time_, log_time_ns);
  last_time_ = std::max(last_time_, log_time_ns);
  ++message_count_;
  ++ch.messages;
}

Status McapWriter::write_streamed(uint16_t channel_id, uint64_t log_time_ns, uint64_t bytes,
                                  const std::function<Status(const Put& put)>& produce) {
  if (file_ == nullptr) return error(ErrorCode::kInvalidArgument, "mcap writer: write_streamed() before open()");
  if (channel_id >= channels_.size())
    return error(ErrorCode::kInvalidArgument, path_ + ": no channel " + std::to_string(channel_id));
  EF_RETURN_IF_ERROR(close_chunk());
  Channel& ch = channels_[channel_id];
  const uint64_t record_bytes = 1 + 8 + 2 + 4 + 8 + 8 + bytes;  // the Message record in the chunk
  ChunkIndex index{};
  index.start_time = index.end_time = log_time_ns;
  index.offset = offset_;
  index.size = record_bytes;
  std::string head;
  u8(head, kChunk);
  u64(head, 8 + 8 + 8 + 4 + 4 + 8 + record_bytes);
  u64(head, log_time_ns);
  u64(head, log_time_ns);
  u64(head, record_bytes);
  u32(head, 0);   // CRC not computed: the data is streamed
  str(head, "");
  u64(head, record_bytes);
  u8(head, kMessage);
  u64(head, 2 + 4 + 8 + 8 + bytes);
  u16(head, channel_id);
  u32(head, ch.sequence++);
  u64(head, log_time_ns);
  u64(head, log_time_ns);
  EF_RETURN_IF_ERROR(put(head.data(), head.size()));
  uint64_t produced = 0;
  EF_RETURN_IF_ERROR(produce([&](const void* data, std::size_t n) -> Status {
    produced += n;
    if (produced > bytes) return error(ErrorCode::kInternal, path_ + ": a streamed message longer than announced");
    return put(data, n);
  }));
  if (produced != bytes)
    return error(ErrorCode::kInternal, path_ + ": a streamed message of " + std::to_string(produced) + " bytes, " +
                                           std::to_string(bytes) + " announced");
  index.length = offset_ - index.offset;
  index.index_offset = offset_;
  index.index_offsets.emplace_back(channel_id, offset_);
  std::string body, rec;
  u16(body, channel_id);
  u32(body, 16);
  u64(body, log_time_ns);
  u64(body, 0);  // the message is the chunk's first record
  record(rec, kMessageIndex, body);
  EF_RETURN_IF_ERROR(put(rec.data(), rec.size()));
  index.index_length = offset_ - index.index_offset;
  chunks_.push_back(std::move(index));
  count_message(ch, log_time_ns);
  return to_disk();
}

Status McapWriter::flush() {
  if (file_ == nullptr) return Status::success();
  return close_chunk();
}

void McapWriter::abandon() {
  if (file_ == nullptr) return;
  __fpurge(file_);  // what the failed write left buffered is not written after it
  std::fclose(file_);
  file_ = nullptr;
}

Status McapWriter::close() {
  if (file_ == nullptr) return Status::success();
  Status s = close_chunk();
  if (s.ok()) {
    std::string rec, body;
    u32(body, data_crc_);
    record(rec, kDataEnd, body);
    s = put(rec.data(), rec.size());
  }
  if (s.ok()) {
    // The summary: schemas, channels, statistics, chunk indexes, each group found by a SummaryOffset.
    const uint64_t summary_start = offset_;
    std::string summary;
    struct Group {
      uint8_t op;
      uint64_t start, length;
    };
    std::vector<Group> groups;
    const auto group = [&](uint8_t op, const auto& add) {
      const uint64_t start = summary_start + summary.size();
      add();
      groups.push_back({op, start, summary_start + summary.size() - start});
    };
    group(kSchema, [&] {
      for (const Schema& sc : schemas_) {
        std::string b;
        u16(b, sc.id);
        str(b, sc.name);
        str(b, sc.encoding);
        str(b, sc.data);
        record(summary, kSchema, b);
      }
    });
    group(kChannel, [&] {
      for (const Channel& ch : channels_) {
        std::string b;
        u16(b, ch.id);
        u16(b, ch.schema_id);
        str(b, ch.topic);
        str(b, ch.encoding);
        u32(b, 0);
        record(summary, kChannel, b);
      }
    });
    group(kStatistics, [&] {
      std::string b;
      u64(b, message_count_);
      u16(b, static_cast<uint16_t>(schemas_.size()));
      u32(b, static_cast<uint32_t>(channels_.size()));
      u32(b, 0);  // attachments
      u32(b, 0);  // metadata
      u32(b, static_cast<uint32_t>(chunks_.size()));
      u64(b, message_count_ > 0 ? first_time_ : 0);
      u64(b, message_count_ > 0 ? last_time_ : 0);
      u32(b, static_cast<uint32_t>(channels_.size() * 10));
      for (const Channel& ch : channels_) {
        u16(b, ch.id);
        u64(b, ch.messages);
      }
      record(summary, kStatistics, b);
    });
    group(kChunkIndex, [&] {
      for (const ChunkIndex& ci : chunks_) {
        std::string b;
        u64(b, ci.start_time);
        u64(b, ci.end_time);
        u64(b, ci.offset);
        u64(b, ci.length);
        u32(b, static_cast<uint32_t>(ci.index_offsets.size() * 10));
        for (const auto& [c, off] : ci.index_offsets) {
          u16(b, c);
          u64(b, off);
        }
        u64(b, ci.index_length);
        str(b, "");
        u64(b, ci.size);
        u64(b, ci.size);
        record(summary, kChunkIndex, b);
      }
    });
    const uint64_t summary_offset_start = summary_start + summary.size();
    for (const Group& g : groups) {
      std::string b;
      u8(b, g.op);
      u64(b, g.start);
      u64(b, g.length);
      record(summary, kSummaryOffset, b);
    }
    // The footer; its CRC covers the summary up to and including summary_offset_start.
    std::string footer;
    u8(footer, kFooter);
    u64(footer, 8 + 8 + 4);
    u64(footer, summary_start);
    u64(footer, summary_offset_start);
    const uint32_t summary_crc = crc(crc(0, summary.data(), summary.size()), footer.data(), footer.size());
    u32(footer, summary_crc);
    s = put(summary.data(), summary.size());
    if (s.ok()) s = put(footer.data(), footer.size());
    if (s.ok()) s = put(kMagic, sizeof kMagic);
  }
  if (s.ok() && (std::fflush(file_) != 0 || ::fsync(::fileno(file_)) != 0))
    s = error(ErrorCode::kIoError, path_ + ": sync failed: " + std::strerror(errno));
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (s.ok() && !closed) return error(ErrorCode::kIoError, path_ + ": close failed: " + std::strerror(errno));
  return s;
}

}  // namespace ef
