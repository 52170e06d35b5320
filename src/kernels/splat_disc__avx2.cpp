// splat_disc for AVX2: 8 pixels of a row per step (see kernels/splat_disc.h for the contract).
#include <immintrin.h>

#include <cstddef>

#include "kernels/splat_disc_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {

void splat_disc__avx2(const SplatDisc& d, const float* ray_x, const float* ray_y, float* key, int32_t* winner,
                       int width) {
  constexpr int kW = 8;
  if (width < kW) {
    splat_disc_ref(d, ray_x, ray_y, key, winner, width);
    return;
  }
  const __m256 nx = _mm256_set1_ps(d.nx), xc = _mm256_set1_ps(d.xc), yc = _mm256_set1_ps(d.yc), zc = _mm256_set1_ps(d.zc);
  const __m256 np = _mm256_set1_ps(d.np), r2 = _mm256_set1_ps(d.r2), tie = _mm256_set1_ps(d.tie), near = _mm256_set1_ps(d.near);
  const __m256 lim = _mm256_set1_ps(-1e-12f), zero = _mm256_setzero_ps();
  const __m256i sid = _mm256_set1_epi32(d.id), iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i last = _mm256_set1_epi32(d.x1);
  for (int y = d.y0; y <= d.y1; ++y) {
    const float dys = ray_y[y];
    const __m256 dy = _mm256_set1_ps(dys);
    const __m256 row_term = _mm256_set1_ps(d.ny * dys + d.nz);
    float* zrow = key + static_cast<std::size_t>(y) * width;
    int32_t* idrow = winner + static_cast<std::size_t>(y) * width;
    for (int cur = d.x0; cur <= d.x1; cur += kW) {
      const int s = cur < width - kW ? cur : width - kW;  // the chunk ends at the border at the latest
      const __m256i xs = _mm256_add_epi32(_mm256_set1_epi32(s), iota);
      const __m256i outside = _mm256_or_si256(_mm256_cmpgt_epi32(_mm256_set1_epi32(cur), xs), _mm256_cmpgt_epi32(xs, last));
      const __m256 dx = _mm256_loadu_ps(ray_x + s);
      const __m256 denom = _mm256_add_ps(_mm256_mul_ps(nx, dx), row_term);
      const __m256 z = _mm256_div_ps(np, _mm256_min_ps(lim, denom));  // lim < denom ? lim : denom
      const __m256 ex = _mm256_sub_ps(_mm256_mul_ps(dx, z), xc);
      const __m256 ey = _mm256_sub_ps(_mm256_mul_ps(dy, z), yc);
      const __m256 ez = _mm256_sub_ps(z, zc);
      const __m256 e2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ex, ex), _mm256_mul_ps(ey, ey)), _mm256_mul_ps(ez, ez));
      const __m256 k = _mm256_add_ps(z, _mm256_mul_ps(_mm256_mul_ps(z, tie), e2));
      const __m256 old_k = _mm256_loadu_ps(zrow + s);
      __m256 wins = _mm256_and_ps(_mm256_cmp_ps(denom, zero, _CMP_LT_OQ), _mm256_cmp_ps(e2, r2, _CMP_LE_OQ));
      wins = _mm256_and_ps(wins, _mm256_and_ps(_mm256_cmp_ps(z, near, _CMP_GE_OQ), _mm256_cmp_ps(k, old_k, _CMP_LT_OQ)));
      wins = _mm256_andnot_ps(_mm256_castsi256_ps(outside), wins);
      _mm256_storeu_ps(zrow + s, _mm256_blendv_ps(old_k, k, wins));
      const __m256i old_id = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(idrow + s));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(idrow + s),
                       _mm256_castps_si256(_mm256_blendv_ps(_mm256_castsi256_ps(old_id), _mm256_castsi256_ps(sid), wins)));
    }
  }
}

}  // namespace ef::kernels
