// Label rendering (SemanticFusion, McCormac et al. ICRA 2017, section V): the map's most likely
// class seen from a camera, for the paper's 2D evaluation and for `edgefusion run --labels-out`.
//
// The view is the last ModelPredictor::predict() (slam/model_prediction.h): its pose and intrinsics.
// For each working pixel (u, v), the surfel it shows is, in this order:
//   1. of the surfels whose centres fell into the pixel's scale x scale cells of the index map and
//      pass the visibility test (semantic/visibility.h) against the measured depth, the nearest to the
//      camera (every surfel of the pool takes part, stable or not);
//   2. else the surfel whose disc owns the pixel in the predicted tracking maps (stable surfels,
//      drawn as discs, so they also cover pixels between centres), if its predicted depth passes the
//      same test;
//   3. else none.
// Where the pixel has no measured depth (or no depth image is given) the test is skipped.
// The pixel gets that surfel's most likely class (label_argmax of its store). Where no surfel is
// seen, or the surfel has had no observation yet (a uniform store), the pixel takes the fallback: the
// single-frame CNN prediction at the working size, as the paper does ("when no reconstruction is
// present for a pixel, we fall back to the predictions of the baseline single frame network"). An
// empty fallback gives 0 (unknown) there.
//
// Cost: one pass over the index map (320x240 at scale 1: 77 k cells; 1.2 M at 4); no allocation.
#pragma once

#include <cstdint>

#include "core/image.h"
#include "core/result.h"
#include "semantic/visibility.h"
#include "slam/model_prediction.h"
#include "slam/surfel_pool.h"

namespace ef::semantic {

struct LabelRenderCounts {
  int64_t from_index_map = 0;  // pixels labelled by a surfel centre in their index cells (rule 1)
  int64_t from_splat = 0;      // pixels labelled by a tracking disc (rule 2)
  int64_t from_fallback = 0;   // pixels that took the fallback (no surfel, or an unobserved one)
};

// Renders into `out` (the predictor's working size). `fallback`: class ids of the same size, or
// empty. `depth`: the frame's measured depth (metres, 0 = none) of the same size, or empty.
// Errors (kInvalidArgument): `out` or a non-empty `fallback` or `depth` of another size than the
// predictor's working image; a surfel id of the maps outside the pool (a pool changed since the
// prediction).
Result<LabelRenderCounts> render_labels(const slam::ModelPredictor& predictor, const slam::SurfelPool& pool,
                                        ImageView<const uint8_t> fallback, ImageView<uint8_t> out,
                                        ImageView<const float> depth = {}, const DepthGate& gate = {});

}  // namespace ef::semantic
