// The index map: which surfel each (sub)pixel of a camera sees, rendered by slam/model_prediction
// from the surfel pool and read by slam/surfel_fusion for data association (ElasticFusion, Whelan et
// al. RSS 2015, section 3.2: surfels are rendered as single points into an index map `scale` times
// finer than the input image along each axis, so that fusion finds up to scale^2 candidate surfels
// per input pixel; ElasticFusion uses 4x, our default is 1x: model_prediction.h).
//
// Grid: `intrinsics` are the working intrinsics scaled by `scale` with the half-pixel-centre
// convention of Intrinsics::scaled_to, so working pixel (u, v) covers index pixels
// [u*scale, u*scale + scale) x [v*scale, v*scale + scale).
// Each index pixel holds the id of the surfel (SurfelPool id) whose centre projects into it and is
// nearest to the camera, or -1, and that surfel's depth (camera z, metres; 0 where id == -1).
// Every surfel of the pool (stable or not) takes part, so fusion can find unstable ones too.
//
// Beside the id, each occupied index pixel holds a copy of what fusion's data association gates a
// candidate on (IndexSurface: the surfel's world-frame normal and its confidence), written when the
// map is rendered. The association then reads the index map row by row instead of the pool's
// columns at scattered ids (slam/surfel_fusion.cpp, visit_cell).
//
// Validity: ids refer to the pool as it was when the map was rendered; a removal in the pool
// invalidates the map (slam/surfel_pool.h). Memory: allocated once by the predictor, 24 bytes per
// index pixel.
#pragma once

#include <cstdint>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/se3.h"
#include "slam/surfel_pool.h"

namespace ef::slam {

// The finest index map: index pixels per working pixel along each axis (ElasticFusion's 4x). Every
// buffer sized for any scale (label fusion's pair list) is sized for this one.
inline constexpr int kMaxIndexScale = 4;

// The surfel of an index pixel as fusion's gates see it.
struct IndexSurface {
  float nx, ny, nz;  // unit normal, world frame
  float confidence;  // SurfelPool::confidence (dimensionless accumulated weight)
};
// kernels/fusion_gates reads a row of surfaces as 4 floats per index pixel.
static_assert(sizeof(IndexSurface) == 4 * sizeof(float), "IndexSurface: four floats, no padding");

struct IndexMap {
  int scale = 1;             // index pixels per working pixel along each axis (1..kMaxIndexScale)
  Intrinsics intrinsics;     // of the index grid
  SE3 T_world_cam;           // the camera pose the map was rendered at (camera to world)
  Image<int32_t> id;         // surfel id, -1 = none
  Image<float> depth;        // camera-frame z of that surfel's centre, metres; 0 = none
  Image<IndexSurface> surface;  // that surfel's normal and confidence at render time; unspecified
                                // where id == -1
  int64_t surfels_drawn = 0; // surfels whose centre landed in the grid (before the depth test)
};

// Fills `map.surface` (allocated to the size of map.id) from `pool` for every index pixel whose id
// is a surfel of the pool. For index maps made without the predictor (tests, tools); the predictor
// writes the same values while it renders.
inline void copy_surfaces_from_pool(const SurfelPool& pool, IndexMap& map) {
  map.surface.allocate(map.id.width(), map.id.height());
  for (std::size_t k = 0; k < map.id.size(); ++k) {
    const int32_t id = map.id.data()[k];
    if (id < 0 || id >= pool.size()) continue;
    map.surface.data()[k] = IndexSurface{pool.nx()[id], pool.ny()[id], pool.nz()[id], pool.confidence()[id]};
  }
}

}  // namespace ef::slam
