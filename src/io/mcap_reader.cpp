#include "io/mcap_reader.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <zlib.h>

namespace ef {

namespace {

constexpr unsigned char kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
enum Op : uint8_t {
  kHeader = 0x01, kFooter = 0x02, kSchema = 0x03, kChannel = 0x04, kMessage = 0x05, kChunk = 0x06,
  kDataEnd = 0x0F,
};
// A chunk larger than this is taken for a corrupt length (our writer's chunks are a few MB).
constexpr uint64_t kMaxChunkBytes = uint64_t(1) << 30;

// A cursor over one record's body; any read past its end sets `bad`.
struct Body {
  const uint8_t* p;
  std::size_t n, pos = 0;
  bool bad = false;
  template <class T>
  T get() {
    T v{};
    if (bad || n - pos < sizeof(T)) {
      bad = true;
      return v;
    }
    for (std::size_t i = 0; i < sizeof(T); ++i) v |= static_cast<T>(static_cast<T>(p[pos + i]) << (8 * i));
    pos += sizeof(T);
    return v;
  }
  std::string text() {  // uint32 length-prefixed
    const uint32_t len = get<uint32_t>();
    if (bad || n - pos < len) {
      bad = true;
      return {};
    }
    std::string s(reinterpret_cast<const char*>(p + pos), len);
    pos += len;
    return s;
  }
  void skip_map() {  // map<string, string>: uint32 byte length, entries
    const uint32_t len = get<uint32_t>();
    if (bad || n - pos < len) {
      bad = true;
      return;
    }
    pos += len;
  }
};

}  // namespace

McapReader::~McapReader() {
  if (fd_ >= 0) ::close(fd_);
}

Error McapReader::corrupt(uint64_t offset, const std::string& what) const {
  return error(ErrorCode::kCorruptData, name_ + ": byte " + std::to_string(offset) + ": " + what);
}

bool McapReader::read_at(uint64_t offset, void* dst, std::size_t bytes) const {
  if (offset > size_ || bytes > size_ - offset) return false;
  if (memory_ != nullptr) {
    std::memcpy(dst, memory_ + offset, bytes);
    return true;
  }
  auto* out = static_cast<char*>(dst);
  while (bytes > 0) {
    const ssize_t got = ::pread(fd_, out, bytes, static_cast<off_t>(offset));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) return false;
    out += got;
    offset += static_cast<uint64_t>(got);
    bytes -= static_cast<std::size_t>(got);
  }
  return true;
}

Status McapReader::open(const std::string& path) {
  name_ = path;
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0)
    return error(errno == ENOENT ? ErrorCode::kNotFound : ErrorCode::kIoError,
                 path + ": cannot open: " + std::strerror(errno));
  const off_t end = ::lseek(fd_, 0, SEEK_END);
  if (end < 0) return error(ErrorCode::kIoError, path + ": cannot size: " + std::strerror(errno));
  size_ = static_cast<uint64_t>(end);
  return walk();
}

Status McapReader::open_memory(const uint8_t* data, std::size_t size, const std::string& name) {
  name_ = name;
  memory_ = data;
  size_ = size;
  return walk();
}

const McapChannel* McapReader::channel(const std::string& topic) const {
  for (const McapChannel& c : channels_)
    if (c.topic == topic) return &c;
  return nullptr;
}

const McapSchema* McapReader::schema(uint16_t id) const {
  for (const McapSchema& s : schemas_)
    if (s.id == id) return &s;
  return nullptr;
}

Status McapReader::read(const McapMessageRef& message, std::string& out) const {
  out.resize(message.bytes);
  if (!read_at(message.offset, out.data(), message.bytes))
    return error(ErrorCode::kIoError, name_ + ": cannot read the message at byte " + std::to_string(message.offset));
  return Status::success();
}

// The records of `p` (n bytes at file offset `base`). Outside chunks this is called per record.
Status McapReader::parse_records(const uint8_t* p, std::size_t n, uint64_t base, bool in_chunk) {
  std::size_t pos = 0;
  while (pos < n) {
    if (n - pos < 9) return corrupt(base + pos, "a record header cut short inside a chunk");
    const uint8_t op = p[pos];
    uint64_t len = 0;
    for (int i = 0; i < 8; ++i) len |= uint64_t(p[pos + 1 + i]) << (8 * i);
    if (len > n - pos - 9) return corrupt(base + pos, "a record of " + std::to_string(len) + " bytes overruns its chunk");
    Body b{p + pos + 9, static_cast<std::size_t>(len)};
    const uint64_t at = base + pos;
    switch (op) {
      case kSchema: {
        McapSchema s;
        s.id = b.get<uint16_t>();
        s.name = b.text();
        s.encoding = b.text();
        s.data = b.text();
        if (b.bad) return corrupt(at, "a Schema record shorter than its fields");
        if (schema(s.id) == nullptr) schemas_.push_back(std::move(s));
        break;
      }
      case kChannel: {
        McapChannel c;
        c.id = b.get<uint16_t>();
        c.schema_id = b.get<uint16_t>();
        c.topic = b.text();
        c.message_encoding = b.text();
        b.skip_map();
        if (b.bad) return corrupt(at, "a Channel record shorter than its fields");
        if (c.schema_id != 0 && schema(c.schema_id) == nullptr)
          return corrupt(at, "channel '" + c.topic + "' names schema " + std::to_string(c.schema_id) +
                                 ", which no record before it defines");
        bool known = false;
        for (const McapChannel& k : channels_) known = known || k.id == c.id;
        if (!known) channels_.push_back(std::move(c));
        break;
      }
      case kMessage: {
        McapMessageRef m;
        m.channel = b.get<uint16_t>();
        m.sequence = b.get<uint32_t>();
        m.log_time = b.get<uint64_t>();
        m.publish_time = b.get<uint64_t>();
        if (b.bad) return corrupt(at, "a Message record shorter than its header");
        McapChannel* ch = nullptr;
        for (McapChannel& c : channels_)
          if (c.id == m.channel) ch = &c;
        if (ch == nullptr)
          return corrupt(at, "a message on channel " + std::to_string(m.channel) + ", which no record before it defines");
        m.offset = at + 9 + 22;
        m.bytes = static_cast<uint32_t>(len - 22);
        if (len - 22 > UINT32_MAX) return corrupt(at, "a message larger than 4 GB");
        ++ch->messages;
        messages_.push_back(m);
        break;
      }
      case kHeader:
        if (in_chunk) return corrupt(at, "a Header record inside a chunk");
        profile_ = b.text();
        library_ = b.text();
        if (b.bad) return corrupt(at, "a Header record shorter than its fields");
        break;
      default:
        if (in_chunk) return corrupt(at, "record opcode " + std::to_string(op) + " inside a chunk");
        break;  // message indexes, attachments, metadata...: not needed to replay
    }
    pos += 9 + len;
  }
  return Status::success();
}

Status McapReader::walk() {
  unsigned char magic[8];
  if (!read_at(0, magic, 8) || std::memcmp(magic, kMagic, 8) != 0)
    return error(ErrorCode::kCorruptData, name_ + ": not an MCAP file (bad magic)");
  uint64_t pos = 8;
  const auto cut = [&](uint64_t at, const std::string& why) {
    warning_ = name_ + ": the log ends at byte " + std::to_string(at) + " (" + why + "): " +
               std::to_string(size_ - at) + " bytes after it are left out; " + std::to_string(messages_.size()) +
               " messages in " + std::to_string(chunks_) + " whole chunks are read";
    return Status::success();
  };
  while (true) {
    if (pos == size_) return cut(pos, "no DataEnd record: a log that was not closed");
    uint8_t head[9];
    if (!read_at(pos, head, 9)) return cut(pos, "a record header cut short");
    const uint8_t op = head[0];
    uint64_t len = 0;
    for (int i = 0; i < 8; ++i) len |= uint64_t(head[1 + i]) << (8 * i);
    if (len > size_ - pos - 9) return cut(pos, "a record of " + std::to_string(len) + " bytes runs past the end");
    if (op == kDataEnd || op == kFooter) return Status::success();
    if (op == kChunk) {
      if (len > kMaxChunkBytes) return corrupt(pos, "a chunk of " + std::to_string(len) + " bytes");
      scratch_.resize(len);
      if (!read_at(pos + 9, scratch_.data(), len)) return cut(pos, "a chunk that cannot be read");
      Body b{reinterpret_cast<const uint8_t*>(scratch_.data()), static_cast<std::size_t>(len)};
      b.get<uint64_t>();  // start and end times
      b.get<uint64_t>();
      const uint64_t uncompressed = b.get<uint64_t>();
      const uint32_t crc = b.get<uint32_t>();
      const std::string compression = b.text();
      const uint64_t records = b.get<uint64_t>();
      if (b.bad || records != len - b.pos) return corrupt(pos, "a Chunk record whose sizes do not add up");
      if (!compression.empty())
        return error(ErrorCode::kUnsupported, name_ + ": byte " + std::to_string(pos) + ": a chunk compressed with '" +
                                                  compression + "' (this reader reads uncompressed chunks only)");
      if (uncompressed != records) return corrupt(pos, "an uncompressed chunk whose two sizes differ");
      const uint8_t* r = b.p + b.pos;
      if (crc != 0 && ::crc32(0, r, static_cast<uInt>(records)) != crc)
        return cut(pos, "a chunk whose CRC does not match its bytes");
      EF_RETURN_IF_ERROR(parse_records(r, records, pos + 9 + b.pos, true));
      ++chunks_;
    } else if (op == kHeader || op == kSchema || op == kChannel || op == kMessage) {
      scratch_.resize(len);
      if (!read_at(pos + 9, scratch_.data(), len)) return cut(pos, "a record that cannot be read");
      // parse_records wants the record with its header: rebuild it in front of the body.
      std::string rec(reinterpret_cast<const char*>(head), 9);
      rec += scratch_;
      EF_RETURN_IF_ERROR(parse_records(reinterpret_cast<const uint8_t*>(rec.data()), rec.size(), pos, false));
    }
    pos += 9 + len;
  }
}

}  // namespace ef
