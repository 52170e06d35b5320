// The depth of one pyramid level from the finer one, shared by the current frame's pyramid
// (slam/preprocess.h) and the predicted model's (slam/model_prediction.h), so that the tracker's
// reference and current pyramids are smoothed by the same rule.
//
// Coarse pixel (x, y) covers finer pixels 2x, 2x+1 and 2y, 2y+1 (Intrinsics::pyramid_level); its
// centre is at finer coordinate 2x + 0.5, where the 4x4 window 2x-1 .. 2x+2 with binomial weights
// [1 3 3 1] x [1 3 3 1] is centred. The near surface of the central 2x2 block (its depths within
// threshold_m of the block's nearest) gives a reference depth, their mean; window depths further than
// threshold_m from it are left out (KinectFusion's pyramid: 3 sigma_depth), so a pixel on a step edge
// takes one surface rather than a depth between, and testing against the mean rather than the
// nearest keeps the selection symmetric, so a steep slope is not biased toward its near side. A
// block without any depth gives none (0): holes are not filled.
//
// Depths in metres, 0 = none. The interior of each row is kernels/pyramid_row (SIMD across the row;
// measured on 7-Scenes: see docs/results.md, issue 31), its border here. No allocation; any sizes
// with coarse <= fine / 2 per axis.
#pragma once

#include "core/image.h"

namespace ef::slam {

// Every pixel of `coarse` from `fine` by the rule above.
void downsample_depth(const Image<float>& fine, Image<float>& coarse, float threshold_m);

// The same depth, and each coarse pixel's intensity from the finer intensities: the same [1 3 3 1] x
// [1 3 3 1] window over the finer pixels that have depth, normalised by the weight used; 0 where the
// coarse pixel has no depth or no finer pixel has (the model prediction's pyramid: only predicted
// pixels carry colour).
void downsample_depth_intensity(const Image<float>& fine_depth, const Image<float>& fine_intensity,
                                Image<float>& coarse_depth, Image<float>& coarse_intensity, float threshold_m);

}  // namespace ef::slam
