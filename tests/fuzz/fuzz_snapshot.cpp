// libFuzzer target for map snapshots (io/snapshot_file.h) and the checkpoints of `edgefusion run`
// inside them (pipeline/checkpoint.h: what `run --resume`, `export` and `view` read). Input: the
// file's bytes.
//   1. As given: the snapshot reader, and every section read back whole.
//   2. With every section's CRC-32 and the end marker's file CRC made right (a structure-aware fix
//      up: without it, a mutation of any byte stops at a checksum), as checkpoint.efs of a scratch
//      folder: find_checkpoint(), load_checkpoint_pool() (export, view) and, when its working size
//      is the one the SLAM below was made for (as `run --resume` checks), restore_checkpoint() into
//      a small SurfelSlam (tests/fuzz/checkpoint_setup.h).
// Any crash, sanitizer report or hang is a bug; an error is the expected answer to a bad file.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "checkpoint_setup.h"
#include "core/stage_stats.h"
#include "fuzz_support.h"
#include "io/snapshot_file.h"
#include "pipeline/checkpoint.h"

namespace {

using ef::fuzz::crc32_of;
using ef::fuzz::get_le32;
using ef::fuzz::put_le32;

uint64_t get_le64(const uint8_t* p) { return uint64_t(get_le32(p)) | uint64_t(get_le32(p + 4)) << 32; }

// docs/snapshot_format.md: 16-byte header, sections of a 16-byte header (tag, u64 bytes, u32 CRC) and
// a payload padded to 8 bytes, the "END " section's payload the CRC of every byte before it.
void fix_snapshot_crcs(std::vector<uint8_t>& b) {
  if (b.size() < 16) return;
  uint32_t file_crc = crc32_of(b.data(), 16);
  std::size_t at = 16;
  while (b.size() - at >= 16) {
    const uint64_t bytes = get_le64(&b[at + 4]);
    const std::size_t payload = at + 16;
    if (bytes > b.size() - payload) return;
    const uint64_t padded = bytes + (8 - bytes % 8) % 8;
    const bool is_end = std::memcmp(&b[at], "END ", 4) == 0;
    if (is_end && bytes >= 4) put_le32(&b[payload], file_crc);
    put_le32(&b[at + 12], crc32_of(&b[payload], static_cast<std::size_t>(bytes)));
    if (is_end || padded > b.size() - payload) return;
    file_crc = static_cast<uint32_t>(::crc32(file_crc, &b[at], static_cast<uInt>(16 + padded)));
    at = payload + static_cast<std::size_t>(padded);
  }
}

void read_sections(const std::string& path) {
  ef::SnapshotReader r;
  if (!r.open(path).ok()) return;
  static const char kTags[][4] = {{'M', 'E', 'T', 'A'}, {'S', 'L', 'A', 'M'}, {'P', 'O', 'O', 'L'}, {'K', 'E', 'Y', 'F'},
                                  {'P', 'O', 'S', 'E'}, {'C', 'N', 'T', 'N'}, {'C', 'N', 'T', 'V'}};
  for (const auto& tag : kTags) {
    if (!r.has(tag)) continue;
    std::vector<unsigned char> bytes(static_cast<std::size_t>(r.size(tag)));
    (void)r.read(tag, bytes.data(), bytes.size());
    (void)r.read(tag, bytes.data(), 1, r.size(tag));  // past the end: an error, never a read
  }
}

void restore(const std::vector<uint8_t>& bytes) {
  const std::filesystem::path& dir = ef::fuzz::scratch_dir();
  ef::fuzz::write_file(dir / ef::pipeline::kCheckpointFile, bytes.data(), bytes.size());
  auto found = ef::pipeline::find_checkpoint(dir.string());
  if (!found.ok()) return;
  (void)ef::pipeline::load_checkpoint_pool(*found);
  const ef::Intrinsics k = ef::fuzz::checkpoint_working_intrinsics();
  if (found->meta.width != k.width || found->meta.height != k.height) return;  // `run --resume` refuses it
  auto slam = ef::slam::SurfelSlam::create(k, ef::fuzz::checkpoint_slam_options());
  if (!slam.ok()) return;
  ef::StageStats stats;
  stats.add_counter("frames");
  stats.add_counter("surfels_created");
  (void)ef::pipeline::restore_checkpoint(*found, *slam, stats);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static ef::fuzz::MemFile file;
  read_sections(file.write(data, size));
  std::vector<uint8_t> fixed(data, data + size);
  fix_snapshot_crcs(fixed);
  restore(fixed);
  return 0;
}
