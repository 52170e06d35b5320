// One interior row of a frame's normal map (slam/preprocess, KinectFusion section 3.2 with central
// differences): each pixel's normal from the vertices of its four neighbours.
//
// Rows: vertex[0], vertex[1], vertex[2] are rows y - 1, y, y + 1 of the vertex map, three floats per
// pixel (x, y, z in metres, the camera frame; z > 0 where the pixel has depth). For pixel x, with C, L,
// R, U, D the vertices of (x, y), (x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1):
//   mx = C.z sx;  my = C.z sy                                (sx, sy: step_x, step_y)
//   ok = C.z > 0 && |L.z - C.z| <= mx && |R.z - C.z| <= mx && |U.z - C.z| <= my && |D.z - C.z| <= my
//        && L.z > 0 && R.z > 0 && U.z > 0 && D.z > 0
//   a = R - L;  b = D - U                                    (per component)
//   c = (b.y a.z - b.z a.y,  b.z a.x - b.x a.z,  b.x a.y - b.y a.x)
//   len2 = c.x c.x + (c.y c.y + c.z c.z);  ok = ok && len2 > 0
//   s = 1 / sqrt(len2);  n = (c.x s, c.y s, c.z s)       (divide: r = sqrt(len2); n = (c.x / r, c.y / r, c.z / r))
//   dot = n.x C.x + (n.y C.y + n.z C.z);  sign = dot > 0 ? -1 : 1   (toward the camera)
//   out = ok ? (sign n.x, sign n.y, sign n.z) : (+0, +0, +0)
// (the sums grouped as Eigen groups a 3-vector's squaredNorm and dot, which this rule replaced).
// Every operation is one IEEE float operation in the order written (kernel files build with
// contraction off), so every variant writes the same bits as the scalar reference. Each pixel depends
// on the inputs only, so a variant may compute a pixel twice (its last step overlaps).
#pragma once

namespace ef::kernels {

struct NormalRow {
  const float* vertex[3] = {nullptr, nullptr, nullptr};  // rows y - 1, y, y + 1, x y z per pixel, at pixel 0
  float step_x = 0;  // largest depth step to a horizontal neighbour, per metre of depth
  float step_y = 0;  // the same to a vertical neighbour
  // Normalise by dividing by the length (the model prediction's normals) rather than multiplying by its
  // reciprocal (the frame's): each caller's rule from before the kernel, so that no output changed.
  bool divide = false;
};

// Writes normal[3 x + k] (k = 0, 1, 2) for x in [x_begin, x_end); needs 1 <= x_begin and x_end <=
// width - 1 of the rows. Dispatched to the best variant for this CPU (platform/cpu_features; EF_ISA
// caps it). No heap allocation.
void normal_row(const NormalRow& r, int x_begin, int x_end, float* normal);

}  // namespace ef::kernels
