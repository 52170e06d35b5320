#include "io/snapshot_file.h"

#include <cerrno>
#include <cstring>
#include <memory>

#include <zlib.h>

namespace ef {

namespace {

constexpr char kMagic[8] = {'E', 'F', 'S', 'N', 'A', 'P', '\r', '\n'};
constexpr char kEndTag[4] = {'E', 'N', 'D', ' '};
constexpr std::size_t kHeaderBytes = 16, kSectionHeaderBytes = 16;

void store_le32(unsigned char* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<unsigned char>(v >> (8 * i));
}
void store_le64(unsigned char* p, uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<unsigned char>(v >> (8 * i));
}
uint32_t load_le32(const unsigned char* p) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= uint32_t(p[i]) << (8 * i);
  return v;
}
uint64_t load_le64(const unsigned char* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= uint64_t(p[i]) << (8 * i);
  return v;
}

// zlib's crc32 takes at most UINT_MAX bytes at a time.
uint32_t crc_update(uint32_t crc, const void* data, std::size_t bytes) {
  const auto* p = static_cast<const Bytef*>(data);
  while (bytes > 0) {
    const uInt n = static_cast<uInt>(std::min<std::size_t>(bytes, 1u << 30));
    crc = static_cast<uint32_t>(::crc32(crc, p, n));
    p += n;
    bytes -= n;
  }
  return crc;
}

std::string tag_text(const char tag[4]) {
  std::string t(tag, 4);
  for (char& c : t)
    if (c < 0x20 || c > 0x7e) c = '?';
  return t;
}

uint64_t padding(uint64_t bytes) { return (8 - bytes % 8) % 8; }

}  // namespace

// ---- Writer ----

SnapshotWriter::~SnapshotWriter() {
  if (file_ != nullptr) std::fclose(file_);
}

Status SnapshotWriter::put(const void* data, std::size_t bytes) {
  if (bytes == 0) return Status::success();
  if (std::fwrite(data, 1, bytes, file_) != bytes)
    return error(ErrorCode::kIoError, path_ + ": write failed at byte " + std::to_string(offset_) + ": " +
                                          std::strerror(errno));
  file_crc_ = crc_update(file_crc_, data, bytes);
  offset_ += bytes;
  return Status::success();
}

Status SnapshotWriter::open(const std::string& path) {
  path_ = path;
  replacement_ = std::make_unique<FileReplacement>(path);
  file_ = std::fopen(replacement_->temp_path().c_str(), "wb");
  if (file_ == nullptr) return error(ErrorCode::kIoError, path + ": cannot create: " + std::strerror(errno));
  sections_ = 0;
  file_crc_ = 0;
  offset_ = 0;
  unsigned char header[kHeaderBytes];
  std::memcpy(header, kMagic, 8);
  store_le32(header + 8, kSnapshotVersion);
  store_le32(header + 12, 0);  // the section count is in the end marker's position: readers count
  return put(header, sizeof header);
}

Status SnapshotWriter::section(const char tag[4], const Part* parts, std::size_t count) {
  if (file_ == nullptr) return error(ErrorCode::kInternal, path_ + ": section() before open()");
  uint64_t bytes = 0;
  uint32_t crc = 0;
  for (std::size_t i = 0; i < count; ++i) {
    bytes += parts[i].bytes;
    crc = crc_update(crc, parts[i].data, parts[i].bytes);
  }
  unsigned char header[kSectionHeaderBytes];
  std::memcpy(header, tag, 4);
  store_le64(header + 4, bytes);
  store_le32(header + 12, crc);
  EF_RETURN_IF_ERROR(put(header, sizeof header));
  for (std::size_t i = 0; i < count; ++i) EF_RETURN_IF_ERROR(put(parts[i].data, parts[i].bytes));
  static constexpr unsigned char kZeros[8] = {};
  EF_RETURN_IF_ERROR(put(kZeros, static_cast<std::size_t>(padding(bytes))));
  ++sections_;
  return Status::success();
}

Status SnapshotWriter::commit(const std::string& previous_path) {
  if (file_ == nullptr) return error(ErrorCode::kInternal, path_ + ": commit() before open()");
  unsigned char end[4];
  store_le32(end, file_crc_);
  EF_RETURN_IF_ERROR(section(kEndTag, end, sizeof end));
  const bool flushed = std::fflush(file_) == 0;
  const int e = errno;
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!flushed || !closed) return error(ErrorCode::kIoError, path_ + ": write failed: " + std::strerror(e));
  if (!previous_path.empty() && std::rename(path_.c_str(), previous_path.c_str()) != 0 && errno != ENOENT)
    return error(ErrorCode::kIoError, path_ + ": cannot keep it as " + previous_path + ": " + std::strerror(errno));
  return replacement_->commit();
}

// ---- Reader ----

SnapshotReader::~SnapshotReader() {
  if (file_ != nullptr) std::fclose(file_);
}

const SnapshotReader::Entry* SnapshotReader::find(const char tag[4]) const {
  for (const Entry& e : entries_)
    if (std::memcmp(e.tag, tag, 4) == 0) return &e;
  return nullptr;
}

bool SnapshotReader::has(const char tag[4]) const { return find(tag) != nullptr; }

uint64_t SnapshotReader::size(const char tag[4]) const {
  const Entry* e = find(tag);
  return e != nullptr ? e->bytes : 0;
}

Status SnapshotReader::open(const std::string& path) {
  path_ = path;
  entries_.clear();
  file_ = std::fopen(path.c_str(), "rb");
  if (file_ == nullptr)
    return error(errno == ENOENT ? ErrorCode::kNotFound : ErrorCode::kIoError,
                 path + ": cannot open snapshot: " + std::strerror(errno));
  const auto corrupt = [&](uint64_t at, const std::string& what) {
    return error(ErrorCode::kCorruptData, path + " at byte " + std::to_string(at) + ": " + what);
  };
  if (fseeko(file_, 0, SEEK_END) != 0) return error(ErrorCode::kIoError, path + ": cannot seek");
  const uint64_t file_size = static_cast<uint64_t>(ftello(file_));
  std::rewind(file_);
  unsigned char header[kHeaderBytes];
  if (file_size < kHeaderBytes || std::fread(header, 1, kHeaderBytes, file_) != kHeaderBytes)
    return corrupt(0, "truncated: " + std::to_string(file_size) + " bytes, shorter than the snapshot header");
  if (std::memcmp(header, kMagic, 8) != 0) return corrupt(0, "not an EdgeFusion snapshot (bad magic)");
  const uint32_t version = load_le32(header + 8);
  if (version != kSnapshotVersion)
    return error(ErrorCode::kUnsupported, path + ": snapshot format version " + std::to_string(version) +
                                              "; this build reads version " + std::to_string(kSnapshotVersion));
  uint32_t file_crc = crc_update(0, header, kHeaderBytes);
  // Every section, its CRC checked as it streams past; the end marker closes the file.
  std::unique_ptr<unsigned char[]> buf(new unsigned char[1 << 16]);
  uint64_t offset = kHeaderBytes;
  while (true) {
    unsigned char sh[kSectionHeaderBytes];
    if (file_size - offset < kSectionHeaderBytes)
      return corrupt(offset, "truncated: the file ends before its end marker (a snapshot cut while written)");
    if (std::fread(sh, 1, kSectionHeaderBytes, file_) != kSectionHeaderBytes)
      return error(ErrorCode::kIoError, path + ": read failed at byte " + std::to_string(offset));
    Entry e{};
    std::memcpy(e.tag, sh, 4);
    e.bytes = load_le64(sh + 4);
    const uint32_t want_crc = load_le32(sh + 12);
    e.offset = offset + kSectionHeaderBytes;
    const std::string name = "section '" + tag_text(e.tag) + "'";
    if (e.bytes > file_size - e.offset || padding(e.bytes) > file_size - e.offset - e.bytes)
      return corrupt(offset, name + " of " + std::to_string(e.bytes) + " bytes runs past the end of the file");
    const bool is_end = std::memcmp(e.tag, kEndTag, 4) == 0;
    const uint32_t crc_before = file_crc;
    file_crc = crc_update(file_crc, sh, kSectionHeaderBytes);
    uint32_t crc = 0;
    unsigned char end_payload[4] = {};
    for (uint64_t left = e.bytes + padding(e.bytes), done = 0; left > 0;) {
      const std::size_t n = static_cast<std::size_t>(std::min<uint64_t>(left, 1 << 16));
      if (std::fread(buf.get(), 1, n, file_) != n)
        return error(ErrorCode::kIoError, path + ": read failed in " + name);
      const std::size_t payload = static_cast<std::size_t>(std::min<uint64_t>(n, e.bytes > done ? e.bytes - done : 0));
      crc = crc_update(crc, buf.get(), payload);
      if (is_end && done == 0 && payload >= 4) std::memcpy(end_payload, buf.get(), 4);
      file_crc = crc_update(file_crc, buf.get(), n);
      done += n;
      left -= n;
    }
    if (crc != want_crc) return corrupt(offset, name + ": CRC-32 mismatch (corrupt snapshot)");
    offset = e.offset + e.bytes + padding(e.bytes);
    if (is_end) {
      if (e.bytes != 4 || load_le32(end_payload) != crc_before)
        return corrupt(offset, "end marker: the file's CRC-32 does not match (corrupt snapshot)");
      if (offset != file_size) return corrupt(offset, std::to_string(file_size - offset) + " bytes after the end marker");
      return Status::success();
    }
    if (find(e.tag) != nullptr) return corrupt(offset, name + " appears twice");
    entries_.push_back(e);
  }
}

Status SnapshotReader::read(const char tag[4], void* dst, std::size_t bytes, uint64_t offset) const {
  const Entry* e = find(tag);
  if (e == nullptr) return error(ErrorCode::kCorruptData, path_ + ": no section '" + tag_text(tag) + "'");
  if (offset > e->bytes || bytes > e->bytes - offset)
    return error(ErrorCode::kCorruptData, path_ + ": section '" + tag_text(tag) + "' has " + std::to_string(e->bytes) +
                                              " bytes, fewer than the " + std::to_string(offset + bytes) + " expected");
  if (bytes == 0) return Status::success();
  if (fseeko(file_, static_cast<off_t>(e->offset + offset), SEEK_SET) != 0 || std::fread(dst, 1, bytes, file_) != bytes)
    return error(ErrorCode::kIoError, path_ + ": read failed in section '" + tag_text(tag) + "'");
  return Status::success();
}

}  // namespace ef
