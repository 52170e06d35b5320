// splat_disc for SSE4.1: 4 pixels of a row per step (see kernels/splat_disc.h for the contract).
#include <smmintrin.h>

#include <cstddef>

#include "kernels/splat_disc_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {

void splat_disc__sse41(const SplatDisc& d, const float* ray_x, const float* ray_y, float* key, int32_t* winner,
                       int width) {
  constexpr int kW = 4;
  if (width < kW) {
    splat_disc_ref(d, ray_x, ray_y, key, winner, width);
    return;
  }
  const __m128 nx = _mm_set1_ps(d.nx), xc = _mm_set1_ps(d.xc), yc = _mm_set1_ps(d.yc), zc = _mm_set1_ps(d.zc);
  const __m128 np = _mm_set1_ps(d.np), r2 = _mm_set1_ps(d.r2), tie = _mm_set1_ps(d.tie), near = _mm_set1_ps(d.near);
  const __m128 lim = _mm_set1_ps(-1e-12f), zero = _mm_setzero_ps();
  const __m128i sid = _mm_set1_epi32(d.id), iota = _mm_setr_epi32(0, 1, 2, 3);
  const __m128i last = _mm_set1_epi32(d.x1);
  for (int y = d.y0; y <= d.y1; ++y) {
    const float dys = ray_y[y];
    const __m128 dy = _mm_set1_ps(dys);
    const __m128 row_term = _mm_set1_ps(d.ny * dys + d.nz);
    float* zrow = key + static_cast<std::size_t>(y) * width;
    int32_t* idrow = winner + static_cast<std::size_t>(y) * width;
    for (int cur = d.x0; cur <= d.x1; cur += kW) {
      const int s = cur < width - kW ? cur : width - kW;  // the chunk ends at the border at the latest
      const __m128i xs = _mm_add_epi32(_mm_set1_epi32(s), iota);
      const __m128i outside = _mm_or_si128(_mm_cmpgt_epi32(_mm_set1_epi32(cur), xs), _mm_cmpgt_epi32(xs, last));
      const __m128 dx = _mm_loadu_ps(ray_x + s);
      const __m128 denom = _mm_add_ps(_mm_mul_ps(nx, dx), row_term);
      const __m128 z = _mm_div_ps(np, _mm_min_ps(lim, denom));  // lim < denom ? lim : denom
      const __m128 ex = _mm_sub_ps(_mm_mul_ps(dx, z), xc);
      const __m128 ey = _mm_sub_ps(_mm_mul_ps(dy, z), yc);
      const __m128 ez = _mm_sub_ps(z, zc);
      const __m128 e2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(ex, ex), _mm_mul_ps(ey, ey)), _mm_mul_ps(ez, ez));
      const __m128 k = _mm_add_ps(z, _mm_mul_ps(_mm_mul_ps(z, tie), e2));
      const __m128 old_k = _mm_loadu_ps(zrow + s);
      __m128 wins = _mm_and_ps(_mm_cmplt_ps(denom, zero), _mm_cmple_ps(e2, r2));
      wins = _mm_and_ps(wins, _mm_and_ps(_mm_cmpge_ps(z, near), _mm_cmplt_ps(k, old_k)));
      wins = _mm_andnot_ps(_mm_castsi128_ps(outside), wins);
      _mm_storeu_ps(zrow + s, _mm_blendv_ps(old_k, k, wins));
      const __m128i old_id = _mm_loadu_si128(reinterpret_cast<const __m128i*>(idrow + s));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(idrow + s),
                       _mm_castps_si128(_mm_blendv_ps(_mm_castsi128_ps(old_id), _mm_castsi128_ps(sid), wins)));
    }
  }
}

}  // namespace ef::kernels
