// normal_row, scalar reference (the specification; see kernels/normal_row.h).
#include <cmath>

#include "kernels/normal_row_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {

void normal_row_ref(const NormalRow& r, int x_begin, int x_end, float* normal) {
  for (int x = x_begin; x < x_end; ++x) {
    const float* c = r.vertex[1] + 3 * x;
    const float* l = c - 3;
    const float* rt = c + 3;
    const float* u = r.vertex[0] + 3 * x;
    const float* d = r.vertex[2] + 3 * x;
    const float mx = c[2] * r.step_x, my = c[2] * r.step_y;
    bool ok = c[2] > 0.0f && std::fabs(l[2] - c[2]) <= mx && std::fabs(rt[2] - c[2]) <= mx &&
              std::fabs(u[2] - c[2]) <= my && std::fabs(d[2] - c[2]) <= my && l[2] > 0.0f && rt[2] > 0.0f &&
              u[2] > 0.0f && d[2] > 0.0f;
    const float ax = rt[0] - l[0], ay = rt[1] - l[1], az = rt[2] - l[2];
    const float bx = d[0] - u[0], by = d[1] - u[1], bz = d[2] - u[2];
    const float cx = by * az - bz * ay, cy = bz * ax - bx * az, cz = bx * ay - by * ax;
    const float len2 = cx * cx + (cy * cy + cz * cz);
    ok = ok && len2 > 0.0f;
    float* out = normal + 3 * x;
    if (!ok) {
      out[0] = out[1] = out[2] = 0.0f;
      continue;
    }
    float nx, ny, nz;
    if (r.divide) {
      const float root = std::sqrt(len2);
      nx = cx / root;
      ny = cy / root;
      nz = cz / root;
    } else {
      const float s = 1.0f / std::sqrt(len2);
      nx = cx * s;
      ny = cy * s;
      nz = cz * s;
    }
    const float dot = nx * c[0] + (ny * c[1] + nz * c[2]);
    const float sign = dot > 0.0f ? -1.0f : 1.0f;
    out[0] = sign * nx;
    out[1] = sign * ny;
    out[2] = sign * nz;
  }
}

}  // namespace ef::kernels
