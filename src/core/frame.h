// One RGB-D frame as every source delivers it and as the frame ring stores it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/image.h"
#include "core/se3.h"

namespace ef {

struct Frame {
  Image<Rgb8> color;       // sRGB; may be empty when a source has no colour (.klg with image size 0)
  Image<float> depth;      // metres along the optical axis, 0 = invalid; same size as color when both exist
  Image<uint8_t> labels;   // class ids (core/classes.h); empty unless has_labels
  double timestamp = 0;    // seconds, source clock (TUM: file stamps; 7-Scenes: index / 30)
  int64_t index = 0;       // 0-based position in the source
  SE3 T_wc;                // reference camera-to-world pose; meaningful only if has_pose
  bool has_pose = false;
  bool has_labels = false;
  std::string name;        // file stem identifying the frame ("frame-000042", "1305031102.175304");
                           // sized once: sources keep names short, see kMaxFrameName
  static constexpr std::size_t kMaxFrameName = 63;

  // Allocates every image at width x height (and reserves the name) so later frames of that size
  // are written without touching the heap.
  void allocate(int width, int height, bool with_labels) {
    color.allocate(width, height);
    depth.allocate(width, height);
    if (with_labels) labels.allocate(width, height);
    name.reserve(kMaxFrameName);
  }
  // Bytes of the three images (what tests check the memory plan's frame figures against).
  std::size_t bytes() const {
    return color.size() * sizeof(Rgb8) + depth.size() * sizeof(float) + labels.size() * sizeof(uint8_t);
  }
  // What allocate(width, height, with_labels) allocates: 7 bytes per pixel, 8 with labels.
  static std::size_t bytes_for(int width, int height, bool with_labels) {
    const std::size_t px = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    return px * (sizeof(Rgb8) + sizeof(float) + (with_labels ? sizeof(uint8_t) : 0));
  }
};

// Copies everything but the images (timestamp, index, pose, name). has_labels is left to the caller,
// which knows whether it copied a label image.
inline void copy_frame_metadata(const Frame& src, Frame& dst) {
  dst.timestamp = src.timestamp;
  dst.index = src.index;
  dst.T_wc = src.T_wc;
  dst.has_pose = src.has_pose;
  dst.name.assign(src.name, 0, Frame::kMaxFrameName);
}

// Copies `src` into `dst` without allocating when dst was allocated at the same size.
inline void copy_frame(const Frame& src, Frame& dst) {
  dst.color = src.color;
  dst.depth = src.depth;
  if (src.has_labels) dst.labels = src.labels;
  dst.has_labels = src.has_labels;
  copy_frame_metadata(src, dst);
}

}  // namespace ef
