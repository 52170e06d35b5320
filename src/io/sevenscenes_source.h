// Microsoft 7-Scenes sequence folder reader: `7scenes:DIR[?fx=..&fy=..&cx=..&cy=..]`.
//
//   frame-NNNNNN.color.jpg (or .color.png)  colour
//   frame-NNNNNN.depth.png                  16-bit depth in millimetres; 0 and 65535 = invalid
//   frame-NNNNNN.pose.txt                   4x4 camera-to-world matrix (metres), optional: when
//                                           any frame has one, every frame must
//   camera-intrinsics.txt                   optional 3x3 K; default fx = fy = 585, cx = 320, cy = 240
// Frames are numbered from 0 without gaps; frame i has timestamp i / 30 s and name "frame-NNNNNN".
// A missing file, a colour/depth size mismatch or a malformed pose is an error naming the file.
#pragma once

#include <memory>
#include <string>
#include <string_view>

#include "core/intrinsics.h"
#include "core/se3.h"
#include "io/frame_source.h"

namespace ef {

// Parses a pose file's text: 16 numbers (4 rows of 4), the last row 0 0 0 1, a rotation block
// orthonormal within 1e-3 with determinant +1. `file` names the file in errors.
Result<SE3> parse_7scenes_pose(std::string_view text, const std::string& file);

// Parses camera-intrinsics.txt text: a 3x3 matrix [fx 0 cx; 0 fy cy; 0 0 1]. Width/height left 0.
Result<Intrinsics> parse_7scenes_intrinsics(std::string_view text, const std::string& file);

// Opens a 7-Scenes sequence folder; uri.path is the folder.
Result<std::unique_ptr<FrameSource>> open_7scenes(const SourceUri& uri);

}  // namespace ef
