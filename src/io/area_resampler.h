// Area-average resampling of colour images between two fixed sizes at any ratio, with every table
// and buffer made at creation: for a per-frame path that must not allocate (OpenCV's INTER_AREA,
// which resample_frame uses, takes its tables from the heap on every call when the ratio is not an
// integer, e.g. the 320x240 working frame to the real-camera network's 257x193).
//
// Output pixel x covers the source interval [x * s, (x + 1) * s) with s = source / output size;
// each source pixel weighs by its overlap with that interval (the box filter OpenCV's INTER_AREA
// applies when shrinking). Enlarging along an axis (s < 1) takes the nearest source pixel instead.
// Rows first: the weighted source rows are summed into a float row, then the columns; rounding to
// nearest, half up. Not bit-identical to OpenCV (its fixed-point path rounds differently).
//
// Threads: run() uses the object's own row buffer: one thread at a time.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/image.h"
#include "core/result.h"

namespace ef {

class AreaResampler {
 public:
  // Tables for src_w x src_h -> dst_w x dst_h (each 1..16384). Errors: kInvalidArgument.
  static Result<AreaResampler> create(int src_w, int src_h, int dst_w, int dst_h);
  // Bytes create() allocates for these sizes; bytes() of a created one.
  static std::size_t bytes_for(int src_w, int src_h, int dst_w, int dst_h);
  std::size_t bytes() const;

  // src must be src_w x src_h and dst dst_w x dst_h (checked: false otherwise, nothing written).
  bool run(ImageView<const Rgb8> src, ImageView<Rgb8> dst);

  int src_width() const { return src_w_; }
  int src_height() const { return src_h_; }

 private:
  struct Tap {
    int32_t index;  // source pixel
    float weight;   // its share of the output pixel, the shares summing to 1
  };
  // Taps of every output position along one axis: tap [first[o], first[o + 1]).
  struct Axis {
    std::vector<int32_t> first;
    std::vector<Tap> taps;
  };
  static Axis make_axis(int src, int dst);
  static std::size_t axis_taps(int src, int dst);

  int src_w_ = 0, src_h_ = 0, dst_w_ = 0, dst_h_ = 0;
  Axis x_, y_;
  std::vector<float> row_;  // src_w x 3: the weighted sum of the source rows of one output row
};

}  // namespace ef
