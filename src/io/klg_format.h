// ElasticFusion .klg logs: reader (a FrameSource) and writer.
//
// Layout, all little-endian: int32 frame count; per frame: int64 timestamp (microseconds),
// int32 depth size, int32 image size, the depth bytes, the colour bytes.
//   depth:  size == W*H*2 -> raw uint16 millimetres, otherwise a zlib stream of them.
//   colour: size == W*H*3 -> raw RGB; 0 -> no colour; otherwise a JPEG.
// The resolution is not stored: the URI says it (`klg:FILE?size=WxH`, default 640x480), or the side
// file "FILE.intrinsics.txt" that `edgefusion convert --to klg:FILE` writes beside it (issue 33: the
// size and the camera travel with the recording).
//
// Reader decisions:
//   * Opening walks every frame header, so size fields outside 1..W*H*2 (depth) or 0..W*H*3
//     (colour), decreasing timestamps and bytes after the counted frames that are not frames are
//     reported at open, naming the file, the frame index and its byte offset.
//   * A recording cut while written (a kill, a power cut, a full disk) is read up to its last whole
//     frame: a count larger than the frames present (or 0, a count never written) and a part frame
//     at the end are not errors but SourceInfo::warning, which says how many frames are read and
//     how many bytes are left out. A file without a single whole frame is an error.
//   * Depth 0 = invalid; every other value is valid (millimetres -> metres).
//   * Size and intrinsics come from the side file when there is one (its size unless the URI gives
//     size=, its intrinsics scaled to that size); else fx = fy = 525, cx = 319.5, cy = 239.5 at
//     640x480 (ElasticFusion's defaults), scaled to `size` (Intrinsics::scaled_to), with a warning
//     that they are assumed. fx, fy, cx, cy query keys override either. A side file that does not
//     parse is an error naming it and its line.
//   * Frame.name is "frame-NNNNNN" (index), Frame.timestamp the stored microseconds / 1e6.
//   * A log in which no frame has colour gives frames with an empty colour image (has_color =
//     false); in a log that mixes, frames without colour get a black image.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "core/frame.h"
#include "io/frame_source.h"

namespace ef {

// Opens `klg:FILE[?size=WxH&fx=..&fy=..&cx=..&cy=..]`.
Result<std::unique_ptr<FrameSource>> open_klg(const SourceUri& uri);

// The same reader over bytes in memory (tests, fuzzing). `data` must outlive the source; `name`
// stands for the file name in errors.
Result<std::unique_ptr<FrameSource>> open_klg_memory(const uint8_t* data, std::size_t size, int width, int height,
                                                     const std::string& name);

// The side file of a .klg: "<klg path>.intrinsics.txt", two comment lines and one line
// "width height fx fy cx cy" (pixels).
std::string klg_side_file(const std::string& klg_path);
// Writes it (whole or not at all). Errors name the file.
Status write_klg_side_file(const std::string& klg_path, const Intrinsics& intrinsics);
// Reads it: the size and intrinsics it holds. Errors (kCorruptData) name the file and what is wrong.
Result<Intrinsics> read_klg_side_file(const std::string& path);

struct KlgWriteOptions {
  bool compress_depth = true;  // zlib (fastest level); falls back to raw when it would not shrink
  int jpeg_quality = 90;       // 1..100 for JPEG colour; 0 writes raw RGB
};

// Writes a .klg log. Depth is stored as uint16 millimetres, round(metres * 1000); invalid (0,
// negative, NaN) and depths beyond 65.535 m are stored as 0. 7-Scenes' millimetre depths
// therefore round-trip exactly. Colour must be empty (stored with size 0) or width x height.
class KlgWriter {
 public:
  KlgWriter() = default;
  KlgWriter(const KlgWriter&) = delete;
  KlgWriter& operator=(const KlgWriter&) = delete;
  ~KlgWriter();  // closes (errors ignored: call close() to see them)

  Status open(const std::string& path, int width, int height, const KlgWriteOptions& options = {});
  // Appends a frame and then updates the frame count in the header, so that a file cut at any
  // moment holds whole frames and (nearly always) the right count. A failed write (a full disk)
  // cuts the file back to its whole frames and names the reason.
  Status write(const Frame& frame);
  // Syncs the file to the disk and closes it.
  Status close();

  int64_t frames_written() const { return frames_; }
  bool is_open() const { return file_ != nullptr; }

 private:
  Error io_error(const std::string& what) const;
  bool patch_count();  // the frame count at byte 0

  std::FILE* file_ = nullptr;
  std::string path_;
  int width_ = 0, height_ = 0;
  KlgWriteOptions options_;
  int64_t frames_ = 0;
  uint64_t end_offset_ = 0;  // bytes of the count and the whole frames
  std::vector<uint8_t> depth_raw_;   // W*H*2 little-endian millimetres, reused
  std::vector<uint8_t> depth_zlib_;  // compressBound(W*H*2), reused
  std::string jpeg_;                 // encoded colour, reused
};

}  // namespace ef
