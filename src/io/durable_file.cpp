#include "io/durable_file.h"

#include <cerrno>
#include <cstdio>
#include <cstring>

#include <fcntl.h>
#include <unistd.h>

namespace ef {

namespace {

Status io_error(const std::string& path, const char* what, int errnum) {
  return error(ErrorCode::kIoError, path + ": " + what + ": " + system_reason(errnum));
}

// fsync of an open path (read-only descriptor: fsync needs no write access on Linux).
Status sync_path(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return io_error(path, "cannot open to sync", errno);
  const int rc = ::fsync(fd);
  const int e = errno;
  ::close(fd);
  if (rc != 0) return io_error(path, "sync failed", e);
  return Status::success();
}

// Writes all of [data, data + n) at `offset`, retrying short writes and EINTR.
bool pwrite_all(int fd, const char* data, std::size_t n, off_t offset) {
  while (n > 0) {
    const ssize_t w = ::pwrite(fd, data, n, offset);
    if (w < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    data += w;
    n -= static_cast<std::size_t>(w);
    offset += w;
  }
  return true;
}

}  // namespace

std::string system_reason(int errnum) { return std::strerror(errnum); }

std::string folder_of(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

Status sync_folder(const std::string& folder) {
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return io_error(folder, "cannot open folder to sync", errno);
  const int rc = ::fsync(fd);
  const int e = errno;
  ::close(fd);
  // Some file systems (and some container overlays) cannot sync a folder; the rename is done.
  if (rc != 0 && e != EINVAL && e != EROFS) return io_error(folder, "folder sync failed", e);
  return Status::success();
}

Status write_file_whole(const std::string& path, std::initializer_list<FilePiece> pieces) {
  FileReplacement replacement(path);
  std::FILE* f = std::fopen(replacement.temp_path().c_str(), "wb");
  if (!f) return error(ErrorCode::kIoError, path + ": cannot create: " + std::strerror(errno));
  bool wrote = true;
  for (const FilePiece& p : pieces) wrote = wrote && (p.bytes == 0 || std::fwrite(p.data, 1, p.bytes, f) == p.bytes);
  wrote = wrote && std::fflush(f) == 0;
  const int e = errno;
  const bool closed = std::fclose(f) == 0;
  if (!wrote || !closed) return error(ErrorCode::kIoError, path + ": write failed: " + std::strerror(e));
  return replacement.commit();
}

// ---- FileReplacement ----

FileReplacement::FileReplacement(std::string path, Durability durability)
    : path_(std::move(path)), temp_(path_ + ".partial"), durability_(durability) {}

FileReplacement::~FileReplacement() { abandon(); }

void FileReplacement::abandon() {
  if (done_) return;
  done_ = true;
  ::unlink(temp_.c_str());  // may not exist: the writer could not create it
}

Status FileReplacement::commit() {
  if (done_) return error(ErrorCode::kInternal, path_ + ": committed or abandoned already");
  if (durability_ == Durability::kSynced) {
    if (Status s = sync_path(temp_); !s.ok()) {
      abandon();
      return s;
    }
  }
  if (::rename(temp_.c_str(), path_.c_str()) != 0) {
    const int e = errno;
    abandon();
    return io_error(path_, "cannot rename the finished .partial into place", e);
  }
  done_ = true;
  if (durability_ == Durability::kSynced) return sync_folder(folder_of(path_));
  return Status::success();
}

// ---- RewrittenFile ----

RewrittenFile::~RewrittenFile() {
  if (fd_ >= 0) {
    ::close(fd_);
    ::unlink(next_.c_str());
  }
}

void RewrittenFile::open(std::string path, std::size_t reserve_bytes) {
  path_ = std::move(path);
  folder_ = folder_of(path_);
  const std::size_t slash = path_.find_last_of('/');
  const std::string name = slash == std::string::npos ? path_ : path_.substr(slash + 1);
  next_ = (folder_ == "." && slash == std::string::npos ? std::string() : folder_ + "/") + "." + name + ".next";
  reserve_bytes_ = reserve_bytes;
  reserve();
}

void RewrittenFile::reserve() {
  if (fd_ >= 0) return;
  fd_ = ::open(next_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) return;
  // posix_fallocate returns the error (it does not set errno); no space: no reserve this time.
  if (reserve_bytes_ > 0 && ::posix_fallocate(fd_, 0, static_cast<off_t>(reserve_bytes_)) != 0) {
    ::close(fd_);
    ::unlink(next_.c_str());
    fd_ = -1;
  }
}

Status RewrittenFile::write(std::string_view text) {
  if (path_.empty()) return error(ErrorCode::kInternal, "RewrittenFile: write() before open()");
  if (fd_ < 0) {
    fd_ = ::open(next_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd_ < 0) return io_error(next_, "cannot create", errno);
  }
  // Into the reserved blocks from offset 0, then cut to the text's length (which frees the rest).
  const bool ok = pwrite_all(fd_, text.data(), text.size(), 0) &&
                  ::ftruncate(fd_, static_cast<off_t>(text.size())) == 0 && ::fdatasync(fd_) == 0;
  const int e = errno;
  ::close(fd_);
  fd_ = -1;
  if (!ok) {
    ::unlink(next_.c_str());
    reserve();  // the failed version's blocks are free again
    return io_error(path_, "write failed", e);
  }
  if (::rename(next_.c_str(), path_.c_str()) != 0) {
    const int re = errno;
    ::unlink(next_.c_str());
    return io_error(path_, "cannot rename the new version into place", re);
  }
  Status synced = sync_folder(folder_);
  reserve();
  return synced;
}

}  // namespace ef
