// TUM RGB-D folder reader (also ICL-NUIM in TUM layout): `tum:DIR[?fx=..&fy=..&cx=..&cy=..]`.
//
// Folder layout:
//   rgb.txt, depth.txt   "timestamp path" lines, '#' comments; timestamps in seconds, strictly
//                        increasing; paths relative to DIR.
//   groundtruth.txt      optional: "timestamp tx ty tz qx qy qz qw" (camera-to-world, metres).
//   labels/<stem>.png    optional: 8-bit class-id image per frame, <stem> = the rgb file's stem.
//                        When labels/ exists every frame must have one.
//   intrinsics.txt       optional (ours, written by TumWriter): one line "fx fy cx cy" in pixels of
//                        the images in the folder. fy may be negative (ICL-NUIM flips y).
// Depth PNGs are 16-bit at 5000 units per metre, 0 = invalid.
//
// Decisions:
//   * Association as TUM's associate.py: every depth/rgb pair closer than 0.02 s is a candidate;
//     pairs are taken greedily by increasing time difference, each image used at most once.
//     Frames are ordered by rgb timestamp; Frame.timestamp is the rgb timestamp, Frame.name the rgb
//     file stem.
//   * Pose of a frame (when groundtruth.txt exists): the groundtruth samples just before and
//     after the frame's timestamp are interpolated (translation linearly, rotation by slerp),
//     provided the nearer of them is within 0.02 s; before the first / after the last sample the
//     nearest is used when within 0.02 s. Otherwise the frame has has_pose = false.
//   * Intrinsics: intrinsics.txt when present, else the TUM defaults fx = fy = 525, cx = 319.5,
//     cy = 239.5 for 640x480 (scaled to the images' size when they differ). Query keys fx, fy, cx,
//     cy override single values of either.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/intrinsics.h"
#include "core/time_association.h"
#include "core/se3.h"
#include "io/frame_source.h"

namespace ef {

// Largest time difference for associating images, and images with groundtruth, seconds.
constexpr double kTumMaxTimeDifference = 0.02;

struct TimedPath {
  double timestamp = 0;  // seconds
  std::string path;      // as written in the list
};

struct StampedPose {
  double timestamp = 0;  // seconds
  SE3 T_wc;
};

// Parses rgb.txt / depth.txt text. `file` names the file in errors (kCorruptData, with the line:
// garbage numbers, missing or extra fields, timestamps that do not increase).
Result<std::vector<TimedPath>> parse_tum_list(std::string_view text, const std::string& file);

// Parses groundtruth.txt text ("timestamp tx ty tz qx qy qz qw"; quaternion normalised, a
// near-zero quaternion is an error; timestamps strictly increasing).
Result<std::vector<StampedPose>> parse_tum_groundtruth(std::string_view text, const std::string& file);

// Parses intrinsics.txt text: one data line "fx fy cx cy" (pixels). Width and height are left 0.
Result<Intrinsics> parse_tum_intrinsics(std::string_view text, const std::string& file);

// rgb/depth pairing uses associate_timestamps() from core/time_association.h.

// Pose at time t from increasing groundtruth samples, by the rule above. False when none.
bool lookup_pose(const std::vector<StampedPose>& groundtruth, double t, double max_dt, SE3& out);

// Opens a TUM RGB-D folder; uri.path is the folder.
Result<std::unique_ptr<FrameSource>> open_tum(const SourceUri& uri);

}  // namespace ef
