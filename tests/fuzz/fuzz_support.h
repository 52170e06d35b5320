// What several fuzz targets share: the fuzzer's bytes as a file for the parsers that read a path
// (an in-memory file, no disk), a scratch folder of this process on tmpfs for those that also write
// beside their input, and checksum fix-ups so that mutations reach the code behind a CRC.
//
// Everything here is per process (libFuzzer's -jobs / -fork run several) and removed at exit.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <sys/mman.h>
#include <unistd.h>
#include <zlib.h>

namespace ef::fuzz {

// A memfd holding the last bytes given; path() opens it again from offset 0 ("/proc/self/fd/N").
// Writing is one ftruncate and one pwrite: no disk, no directory entry.
class MemFile {
 public:
  MemFile() {
    fd_ = ::memfd_create("ef-fuzz", 0);
    if (fd_ < 0) std::abort();  // Linux >= 3.17: the fuzz targets need it
    path_ = "/proc/self/fd/" + std::to_string(fd_);
  }
  ~MemFile() { ::close(fd_); }
  MemFile(const MemFile&) = delete;
  MemFile& operator=(const MemFile&) = delete;

  // The file's contents become `data`; returns its path.
  const std::string& write(const uint8_t* data, std::size_t size) {
    if (::ftruncate(fd_, 0) != 0) std::abort();
    std::size_t done = 0;
    while (done < size) {
      const ssize_t n = ::pwrite(fd_, data + done, size - done, static_cast<off_t>(done));
      if (n <= 0) std::abort();
      done += static_cast<std::size_t>(n);
    }
    return path_;
  }
  const std::string& path() const { return path_; }

 private:
  int fd_ = -1;
  std::string path_;
};

// A folder of this process under /dev/shm (tmpfs: renames and syncs cost nothing), or under
// $TMPDIR where there is none; removed with everything in it when the process exits.
inline const std::filesystem::path& scratch_dir() {
  static const std::filesystem::path dir = [] {
    std::error_code ec;
    std::filesystem::path base = std::filesystem::is_directory("/dev/shm", ec) ? "/dev/shm" : "";
    if (base.empty()) base = std::filesystem::temp_directory_path();
    std::filesystem::path d = base / ("ef-fuzz-" + std::to_string(::getpid()));
    std::filesystem::remove_all(d, ec);
    std::filesystem::create_directories(d);
    static const std::string keep = d.string();
    std::atexit([] {
      std::error_code e;
      std::filesystem::remove_all(keep, e);
    });
    return d;
  }();
  return dir;
}

// Writes `data` to `path` whole (aborts on failure: the scratch folder is ours).
inline void write_file(const std::filesystem::path& path, const void* data, std::size_t size) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
}

inline uint32_t crc32_of(const uint8_t* p, std::size_t n) {
  return static_cast<uint32_t>(::crc32(0L, p, static_cast<uInt>(n)));
}
inline uint32_t get_le32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}
inline void put_le32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
inline uint32_t get_be32(const uint8_t* p) {
  return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | uint32_t(p[3]);
}
inline void put_be32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (24 - 8 * i));
}

// PNG: every chunk's CRC (big-endian, over type and data) made right, as far as the chunks' lengths
// lead, in the PNG of `size` bytes at `b` (signature included); stops after IEND. Returns whether a
// byte changed.
inline bool fix_png_crcs(uint8_t* b, std::size_t size) {
  bool changed = false;
  std::size_t at = 8;  // after the signature
  while (size >= 12 && at <= size - 12) {
    const uint32_t len = get_be32(&b[at]);
    if (len > size - at - 12) break;
    const uint32_t crc = crc32_of(&b[at + 4], 4 + std::size_t(len));
    if (get_be32(&b[at + 8 + len]) != crc) {
      put_be32(&b[at + 8 + len], crc);
      changed = true;
    }
    const bool end = std::memcmp(&b[at + 4], "IEND", 4) == 0;
    at += 12 + std::size_t(len);
    if (end) break;
  }
  return changed;
}
inline bool fix_png_crcs(std::vector<uint8_t>& b) { return fix_png_crcs(b.data(), b.size()); }

// The same for every PNG embedded in `size` bytes at `b` (found by its signature): the images in a
// field log's messages.
inline bool fix_embedded_png_crcs(uint8_t* b, std::size_t size) {
  static const uint8_t kSig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  bool changed = false;
  for (std::size_t at = 0; size >= 8 && at <= size - 8; ++at)
    if (std::memcmp(b + at, kSig, 8) == 0) changed = fix_png_crcs(b + at, size - at) || changed;
  return changed;
}

}  // namespace ef::fuzz
