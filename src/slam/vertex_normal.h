// The vertex and normal maps of one depth image, as the frame's pyramid (slam/preprocess.h) and the
// model prediction's coarse levels (slam/model_prediction.h) both build them.
//
// Vertex map V(u) = D(u) K^-1 [u, 1] (zero where D(u) is not > 0). Normal map N(u) = normalise((V(x,
// y+1) - V(x, y-1)) x (V(x+1, y) - V(x-1, y))) (KinectFusion section 3.2, with central instead of
// forward differences, so that the normal belongs to the pixel's own centre), turned toward the
// camera, zero on the border, next to a pixel without depth and across a depth step steeper than
// step_x / step_y (metres of step per metre of depth, 1 / (f tan(angle)) for a surface at `angle` to
// the ray): kernels/normal_row states the rule and does the interior of every row.
#pragma once

#include <Eigen/Core>

#include "core/image.h"
#include "core/intrinsics.h"

namespace ef::slam {

// Fills `vertex` and `normal` (both K.width x K.height, allocated by the caller) from `depth`
// (metres). `divide`: see kernels::NormalRow::divide. No allocation.
void vertex_normal_maps(const Image<float>& depth, const Intrinsics& K, float step_x, float step_y, bool divide,
                        Image<Eigen::Vector3f>& vertex, Image<Eigen::Vector3f>& normal);

}  // namespace ef::slam
