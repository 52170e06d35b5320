// Writes frames as a TUM RGB-D folder that open_tum() reads back:
//   rgb/<stem>.png     8-bit RGB (black when the frame has no colour)
//   depth/<stem>.png   16-bit, 5000 units per metre, round(metres * 5000); invalid and depths
//                      beyond 13.107 m are 0
//   rgb.txt, depth.txt "timestamp path" with 6 decimals (the same timestamp in both)
//   groundtruth.txt    for frames with a pose: "timestamp tx ty tz qx qy qz qw", 17 significant digits
//   labels/<stem>.png  for frames with labels (8-bit class ids)
//   intrinsics.txt     "fx fy cx cy" when open() got valid intrinsics
// <stem> is Frame.name, or the timestamp with 6 decimals when the name is empty. Existing files of
// the same names are overwritten. Timestamps must increase by at least 1 us; stems must be unique.
// Cut at any moment (issue 29), the folder is readable: each image is whole or absent (renamed into
// place), and a frame's list lines are written whole, after its images, as the frame arrives.
#pragma once

#include <cstdint>
#include <cstdio>
#include <set>
#include <string>

#include "core/frame.h"
#include "core/intrinsics.h"
#include "core/result.h"

namespace ef {

class TumWriter {
 public:
  TumWriter() = default;
  TumWriter(const TumWriter&) = delete;
  TumWriter& operator=(const TumWriter&) = delete;
  ~TumWriter();  // closes (errors ignored: call close() to see them)

  // Creates `dir` (and parents) with rgb/ and depth/.
  Status open(const std::string& dir, const Intrinsics& intrinsics);
  Status write(const Frame& frame);
  Status close();

  int64_t frames_written() const { return frames_; }

 private:
  Status write_line(std::FILE*& f, const char* name, const std::string& line);

  std::string dir_;
  std::FILE* rgb_txt_ = nullptr;
  std::FILE* depth_txt_ = nullptr;
  std::FILE* gt_txt_ = nullptr;  // created at the first frame with a pose
  bool labels_dir_made_ = false;
  bool open_ = false;
  int64_t frames_ = 0;
  double last_timestamp_ = 0;
  std::set<std::string> stems_;
  Image<uint16_t> depth_units_;  // reused
  Image<Rgb8> black_;            // for frames without colour
};

}  // namespace ef
