// The residual rows of the tracker's Gauss-Newton step: for each current pixel, one point-to-plane
// ICP row and one photometric row (Jacobian with respect to a left twist (v, w), residual, weight),
// written in the structure-of-arrays layout that reduce_normal_equations reads
// (kernels/normal_equations.h). The maths is that of slam/tracker.h (ElasticFusion, Whelan et al.
// RSS 2015 section 4.1; KinectFusion projective association, Newcombe et al. ISMAR 2011 section 3.5);
// this kernel evaluates it for one run of pixels of one image row, branch-free in the SIMD variants.
//
// Per current pixel j with vertex p (camera frame, metres; invalid when p.z <= 0), normal n (invalid
// = (0, 0, 0)) and intensity c (grey levels), at the pose T = (R, t) (current -> reference):
//   X = R p + t                                  X_k = ((R_k0 p_x + R_k1 p_y) + R_k2 p_z) + t_k
//   needs p.z > 0 and X.z > 0;  iz = 1 / X.z
//   u = (fx X.x) iz + cx,  v = (fy X.y) iz + cy  (reference pixel, floats)
//   nearest reference pixel (ui, vi) = (floor(u + 0.5), floor(v + 0.5)) when
//     -0.5 < u < width - 0.5 and -0.5 < v < height - 0.5; q, m: reference vertex / normal there
//   ICP row when use_icp, q.z > 0, n and m valid, and with d = X - q, Rn = R n (as X without t):
//     |d|^2 <= icp_max_d2, Rn . m > 0, |Rn x m|^2 <= icp_sin2_max       (|a|^2 = (a_x a_x + a_y a_y) + a_z a_z,
//                                                                     a . b likewise, x the usual cross product)
//     J = (m, X x m), r = m . d, w = 1
//   RGB row when use_rgb, X.z <= rgb_max_depth, 0 <= u < width - 1, 0 <= v < height - 1, and (when
//   rgb_depth_gate) q exists with q.z > 0 and |q.z - X.z| <= rgb_max_depth_diff:
//     x0 = int(u), y0 = int(v), ax = u - x0, ay = v - y0
//     bilinear B(I) = ((w00 I00 + w10 I10) + w01 I01) + w11 I11, w00 = (1 - ax)(1 - ay), w10 = ax (1 - ay),
//                     w01 = (1 - ax) ay, w11 = ax ay   (I10 is x0 + 1, y0)
//     and B(Gx) B(Gx) + B(Gy) B(Gy) >= rgb_min_grad2 (a texture gate: see TrackerOptions::rgb_min_gradient_grey):
//     r = B(I_ref) - c;  gx = (B(Gx) fx) iz, gy = (B(Gy) fy) iz, g = (gx, gy, -((gx X.x + gy X.y) iz))
//     J = (g, X x g), w = 1 if |r| <= rgb_huber_grey else rgb_huber_grey / |r|   (Huber IRLS weight)
//   A pixel without a row in a term gets the row of zeros (J = 0, r = 0, w = 0) in that term.
// Every operation is one IEEE float operation in the order written (no fused multiply-add: kernel
// files build with contraction off), so every variant writes the same bits as the scalar reference
// on every architecture.
//
// Without rgb_depth_gate, and with p a ray (x, y, 1) and t = 0, the RGB rows are those of a
// rotation-only photometric alignment (the last three Jacobian columns): the tracker's SO(3)
// pre-alignment uses the kernel that way.
#pragma once

#include <cstddef>
#include <cstdint>

namespace ef::kernels {

struct TrackRowsParams {
  // Pose current -> reference: R row-major (R[3 * row + col]), t in metres.
  float R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  float t[3] = {0, 0, 0};
  // Reference camera (pixels) and image size.
  float fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;
  // Reference maps. vertex / normal: 3 floats per pixel (x, y, z), pixel (x, y) at
  // map[y * stride + 3 * x]; intensity and gradients: 1 float per pixel at image[y * stride + x].
  // Strides are in floats. Unused maps (ICP off; RGB off) may be null.
  const float* ref_vertex = nullptr;
  const float* ref_normal = nullptr;
  const float* ref_intensity = nullptr;
  const float* ref_grad_x = nullptr;
  const float* ref_grad_y = nullptr;
  std::ptrdiff_t vertex_stride = 0, normal_stride = 0;
  std::ptrdiff_t intensity_stride = 0, grad_x_stride = 0, grad_y_stride = 0;
  // Gates (see above): squared metres, sin^2 of the normal angle, grey levels, metres, metres.
  float icp_max_d2 = 0.01f;
  float icp_sin2_max = 0.117f;
  float rgb_huber_grey = 15.0f;
  float rgb_max_depth_diff = 0.07f;
  float rgb_max_depth = 6.0f;
  // Squared grey levels per pixel: an RGB row needs the reference's gradient (bilinear, before the
  // focal length) with B(Gx)^2 + B(Gy)^2 >= this; 0 keeps every pixel.
  float rgb_min_grad2 = 0.0f;
  bool use_icp = true;
  bool use_rgb = true;
  bool rgb_depth_gate = true;
};

// Pixels of the run: with a valid vertex (p.z > 0), with an ICP row, with an RGB row.
struct TrackRowsCounts {
  int64_t valid = 0, icp = 0, rgb = 0;
};

// Writes the rows of n current pixels: cur_vertex / cur_normal hold 3 floats per pixel (xyz),
// cur_intensity 1 (null when !use_rgb; cur_normal may be null when !use_icp). Row j of a term goes to
// rows[k * stride + j] for component k = 0..7 (J0..J5, r, w); icp_rows (rgb_rows) is not touched and
// may be null when use_icp (use_rgb) is false. Adds the pixel counts to *counts. Every input must be
// finite; coordinates of the reference maps must fit in int32. Dispatched to the best variant for
// this CPU (platform/cpu_features; EF_ISA caps it). No heap allocation.
void track_rows(const TrackRowsParams& params, const float* cur_vertex, const float* cur_normal,
                const float* cur_intensity, std::size_t n, float* icp_rows, float* rgb_rows, std::size_t stride,
                TrackRowsCounts* counts);

}  // namespace ef::kernels
