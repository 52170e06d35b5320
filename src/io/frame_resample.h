// Resampling a frame to the working resolution (320x240 by default) before anything else sees it.
#pragma once

#include "core/frame.h"
#include "core/intrinsics.h"

namespace ef {

// Writes `src` resampled to out's size into `out` (out must be allocated at the working size,
// with labels when src has them). Pixel centres follow Intrinsics::scaled_to.
//   colour: area average (OpenCV INTER_AREA);
//   depth:  for an integer shrink factor f, the mean of the valid depths of each f x f block that
//           lie within 0.05 m of the block's nearest valid depth (so a block across an edge keeps
//           the near surface instead of inventing a depth between surfaces); otherwise nearest.
//   labels: the label of the source pixel nearest to the block centre.
// Metadata (timestamp, pose, name, index) is copied.
void resample_frame(const Frame& src, Frame& out);

}  // namespace ef
