// Files that are whole or absent, whatever happens while they are written (issue 29): a kill -9, a
// crash, a full disk, a power cut.
//
//   FileReplacement  a file written once: the writer writes "<path>.partial", commit() renames it
//                    over <path>. Until then <path> is the earlier version (or absent); a failed or
//                    abandoned write removes the .partial, so its blocks are free again.
//   RewrittenFile    a small file rewritten whole again and again (stats.json): each version replaces
//                    the one before, and the next version's space is reserved on disk beforehand, so
//                    that the last word (a run that failed on a full disk) can still be written.
//
// Durability::kSynced adds fsync of the file before the rename and of the folder after it, so the
// new version survives a power cut too; kAtomic (per-frame images) leaves the syncing to the
// kernel: a process crash never leaves a half file, a power cut may lose the newest ones.
//
// Errors name the file and the system's reason ("No space left on device").
// Threads: an object belongs to one thread.
#pragma once

#include <cstddef>
#include <initializer_list>
#include <string>
#include <string_view>

#include "core/result.h"

namespace ef {

enum class Durability { kAtomic, kSynced };

class FileReplacement {
 public:
  explicit FileReplacement(std::string path, Durability durability = Durability::kSynced);
  ~FileReplacement();  // not committed: the .partial is removed
  FileReplacement(const FileReplacement&) = delete;
  FileReplacement& operator=(const FileReplacement&) = delete;

  const std::string& path() const { return path_; }
  // Where the writer writes: "<path>.partial" in the same folder (a rename never crosses file systems).
  const std::string& temp_path() const { return temp_; }
  // The written .partial becomes <path> (synced first with kSynced). Errors: the .partial missing, a
  // failed sync or rename; the .partial is removed then.
  Status commit();
  // Removes the .partial (a writer that failed).
  void abandon();

 private:
  std::string path_, temp_;
  Durability durability_;
  bool done_ = false;
};

// A file written whole or not at all (a FileReplacement, synced) from pieces in memory, one after
// the other. Errors name the file and the reason (a failed create, write, sync or rename).
struct FilePiece {
  const void* data;
  std::size_t bytes;
};
Status write_file_whole(const std::string& path, std::initializer_list<FilePiece> pieces);

class RewrittenFile {
 public:
  static constexpr std::size_t kDefaultReserveBytes = 64 * 1024;

  RewrittenFile() = default;
  ~RewrittenFile();  // removes the reserve; the last version written stays
  RewrittenFile(const RewrittenFile&) = delete;
  RewrittenFile& operator=(const RewrittenFile&) = delete;

  // Reserves `reserve_bytes` for the next version in "<folder>/.<name>.next". A reserve that cannot
  // be made (a full disk) is not an error: the next write then needs the space itself.
  void open(std::string path, std::size_t reserve_bytes = kDefaultReserveBytes);
  // Replaces <path> by `text`, synced (file and folder), then reserves again. Writes into the
  // reserved blocks when the text fits them. Errors name the file and the reason; <path> then keeps
  // its previous version. Allocates nothing once open.
  Status write(std::string_view text);
  const std::string& path() const { return path_; }
  bool reserved() const { return fd_ >= 0; }

 private:
  void reserve();
  std::string path_, next_, folder_;
  std::size_t reserve_bytes_ = 0;
  int fd_ = -1;  // the reserve, open for writing; -1 when none
};

// fsync of a folder, so that a rename or a new file in it survives a power cut.
Status sync_folder(const std::string& folder);
// The folder of a path ("." when it has none).
std::string folder_of(const std::string& path);
// strerror(errnum), the system's words for an errno value.
std::string system_reason(int errnum);

}  // namespace ef
