// fusion_gates, scalar reference (the specification; see kernels/fusion_gates.h).
#include <cmath>
#include <cstdint>

#include "kernels/fusion_gates_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {

void fusion_gates_ref(const FusionGateParams& p, const FusionGateRow& row, int x_begin, int x_end, uint32_t* code) {
  const float yf = static_cast<float>(p.y);
  for (int x = x_begin; x < x_end; ++x) {
    const float z = row.z[x], g = row.gate[x];
    const float fs = p.neg_free_space_factor * g;
    const float nwx = row.nwx[x], nwy = row.nwy[x], nwz = row.nwz[x];
    uint32_t c = 0;
    for (int k = 0; k < 9; ++k) {
      const int r = k / 3, cx = x + k % 3 - 1;
      const int32_t id = p.id[r][cx];
      const bool occupied = (id >= 0) & (id < p.pool_size);
      const float dz = p.depth[r][cx] - z;
      const bool violated = dz < fs;
      const bool depth_ok = !violated & !(std::fabs(dz) > g);
      const float* s = p.surface[r] + 4 * cx;
      const float cos_n = s[0] * nwx + s[1] * nwy + s[2] * nwz;
      const bool normal_ok = !(cos_n < p.cos_normal_gate);
      c |= static_cast<uint32_t>(occupied) << k;
      c |= static_cast<uint32_t>(occupied & depth_ok) << (kGateDepthShift + k);
      c |= static_cast<uint32_t>(occupied & normal_ok) << (kGateNormalShift + k);
      if (id >= p.pool_size) c |= kGateInvalid;
      if (k == 4 && occupied && violated) c |= kGateOwnViolated;
    }
    const bool identity = (std::ceil(row.xi[x] - 0.5f) == static_cast<float>(x)) & (std::ceil(row.yi[x] - 0.5f) == yf);
    if (identity) c |= kGateIdentity;
    code[x] = c;
  }
}

}  // namespace ef::kernels
