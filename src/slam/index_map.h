// The index map: which surfel each (sub)pixel of a camera sees, rendered by slam/model_prediction
// from the surfel pool and read by slam/surfel_fusion for data association (ElasticFusion, Whelan et
// al. RSS 2015, section 3.2: surfels are rendered as single points into an index map `scale` times
// finer than the input image along each axis, so that fusion finds up to scale^2 candidate surfels
// per input pixel; ElasticFusion uses 4x, our default is 2x: model_prediction.h).
//
// Grid: `intrinsics` are the working intrinsics scaled by `scale` with the half-pixel-centre
// convention of Intrinsics::scaled_to, so working pixel (u, v) covers index pixels
// [u*scale, u*scale + scale) x [v*scale, v*scale + scale).
// Each index pixel holds the id of the surfel (SurfelPool id) whose centre projects into it and is
// nearest to the camera, or -1, and that surfel's depth (camera z, metres; 0 where id == -1).
// Every surfel of the pool (stable or not) takes part, so fusion can find unstable ones too.
//
// Validity: ids refer to the pool as it was when the map was rendered; a removal in the pool
// invalidates the map (slam/surfel_pool.h). Memory: allocated once by the predictor.
#pragma once

#include <cstdint>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/se3.h"

namespace ef::slam {

struct IndexMap {
  int scale = 1;             // index pixels per working pixel along each axis (1..4)
  Intrinsics intrinsics;     // of the index grid
  SE3 T_world_cam;           // the camera pose the map was rendered at (camera to world)
  Image<int32_t> id;         // surfel id, -1 = none
  Image<float> depth;        // camera-frame z of that surfel's centre, metres; 0 = none
  int64_t surfels_drawn = 0; // surfels whose centre landed in the grid (before the depth test)
};

}  // namespace ef::slam
