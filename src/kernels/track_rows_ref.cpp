// Scalar reference of track_rows: the specification every SIMD variant reproduces bit for bit
// (kernels/track_rows.h). Each expression is written in the order of the header; with contraction
// off each * + - / rounds to float on its own.
#include <cmath>

#include "kernels/track_rows_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {

namespace {

inline void put_row(float* rows, std::size_t stride, std::size_t j, const float J[6], float r, float w) {
  for (int k = 0; k < 6; ++k) rows[k * stride + j] = J[k];
  rows[6 * stride + j] = r;
  rows[7 * stride + j] = w;
}

inline void put_zero_row(float* rows, std::size_t stride, std::size_t j) {
  for (int k = 0; k < 8; ++k) rows[k * stride + j] = 0.0f;
}

// out = a x b.
inline void cross(const float a[3], const float b[3], float out[3]) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

inline float dot(const float a[3], const float b[3]) { return (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]; }

inline bool nonzero(const float* n) { return n[0] != 0.0f || n[1] != 0.0f || n[2] != 0.0f; }

}  // namespace

void track_rows_ref(const TrackRowsParams& P, const float* cur_vertex, const float* cur_normal,
                    const float* cur_intensity, std::size_t n, float* icp_rows, float* rgb_rows, std::size_t stride,
                    TrackRowsCounts* counts) {
  const float* R = P.R;
  const float u_in_max = static_cast<float>(P.width) - 0.5f, v_in_max = static_cast<float>(P.height) - 0.5f;
  const float u_bi_max = static_cast<float>(P.width - 1), v_bi_max = static_cast<float>(P.height - 1);
  int64_t valid = 0, icp_count = 0, rgb_count = 0;
  for (std::size_t j = 0; j < n; ++j) {
    bool icp_done = false, rgb_done = false;
    const float* p = cur_vertex + 3 * j;
    if (p[2] > 0.0f) {
      ++valid;
      const float X[3] = {((R[0] * p[0] + R[1] * p[1]) + R[2] * p[2]) + P.t[0],
                          ((R[3] * p[0] + R[4] * p[1]) + R[5] * p[2]) + P.t[1],
                          ((R[6] * p[0] + R[7] * p[1]) + R[8] * p[2]) + P.t[2]};
      if (X[2] > 0.0f) {
        const float iz = 1.0f / X[2];
        const float u = (P.fx * X[0]) * iz + P.cx;
        const float v = (P.fy * X[1]) * iz + P.cy;
        const bool inside = u > -0.5f && v > -0.5f && u < u_in_max && v < v_in_max;
        const float* q = nullptr;
        std::ptrdiff_t ui = 0, vi = 0;
        if (inside && (P.use_icp || (P.use_rgb && P.rgb_depth_gate))) {
          ui = static_cast<std::ptrdiff_t>(std::floor(u + 0.5f));
          vi = static_cast<std::ptrdiff_t>(std::floor(v + 0.5f));
          q = P.ref_vertex + vi * P.vertex_stride + 3 * ui;
        }
        const bool q_valid = q != nullptr && q[2] > 0.0f;

        if (P.use_icp && q_valid && nonzero(cur_normal + 3 * j)) {
          const float* m = P.ref_normal + vi * P.normal_stride + 3 * ui;
          if (nonzero(m)) {
            const float* cn = cur_normal + 3 * j;
            const float d[3] = {X[0] - q[0], X[1] - q[1], X[2] - q[2]};
            const float Rn[3] = {(R[0] * cn[0] + R[1] * cn[1]) + R[2] * cn[2],
                                 (R[3] * cn[0] + R[4] * cn[1]) + R[5] * cn[2],
                                 (R[6] * cn[0] + R[7] * cn[1]) + R[8] * cn[2]};
            float c[3];
            cross(Rn, m, c);
            if (dot(d, d) <= P.icp_max_d2 && dot(Rn, m) > 0.0f && dot(c, c) <= P.icp_sin2_max) {
              float J[6] = {m[0], m[1], m[2], 0, 0, 0};
              cross(X, m, J + 3);
              put_row(icp_rows, stride, j, J, dot(m, d), 1.0f);
              icp_done = true;
              ++icp_count;
            }
          }
        }

        const bool depth_ok = !P.rgb_depth_gate || (q_valid && std::fabs(q[2] - X[2]) <= P.rgb_max_depth_diff);
        if (P.use_rgb && depth_ok && X[2] <= P.rgb_max_depth && u >= 0.0f && v >= 0.0f && u < u_bi_max &&
            v < v_bi_max) {
          const int x0 = static_cast<int>(u), y0 = static_cast<int>(v);
          const float ax = u - static_cast<float>(x0), ay = v - static_cast<float>(y0);
          const float w00 = (1.0f - ax) * (1.0f - ay), w10 = ax * (1.0f - ay), w01 = (1.0f - ax) * ay, w11 = ax * ay;
          const auto bilinear = [&](const float* im, std::ptrdiff_t s) {
            const float* r0 = im + y0 * s + x0;
            const float* r1 = r0 + s;
            return ((w00 * r0[0] + w10 * r0[1]) + w01 * r1[0]) + w11 * r1[1];
          };
          const float bgx = bilinear(P.ref_grad_x, P.grad_x_stride), bgy = bilinear(P.ref_grad_y, P.grad_y_stride);
          if (bgx * bgx + bgy * bgy >= P.rgb_min_grad2) {
            const float r = bilinear(P.ref_intensity, P.intensity_stride) - cur_intensity[j];
            const float gx = (bgx * P.fx) * iz;
            const float gy = (bgy * P.fy) * iz;
            float J[6] = {gx, gy, -((gx * X[0] + gy * X[1]) * iz), 0, 0, 0};
            cross(X, J, J + 3);
            const float a = std::fabs(r);
            const float w = a <= P.rgb_huber_grey ? 1.0f : P.rgb_huber_grey / a;
            put_row(rgb_rows, stride, j, J, r, w);
            rgb_done = true;
            ++rgb_count;
          }
        }
      }
    }
    if (P.use_icp && !icp_done) put_zero_row(icp_rows, stride, j);
    if (P.use_rgb && !rgb_done) put_zero_row(rgb_rows, stride, j);
  }
  counts->valid += valid;
  counts->icp += icp_count;
  counts->rgb += rgb_count;
}

}  // namespace ef::kernels
