// crf_rows at the AVX-512 level (only F is used; named after the repo's level, see kernels/variants.h):
// one 16-float row is one zmm, so a slice is 7 load-multiply-adds into one register, a splat 7
// read-modify-writes. Separate VMULPS and VADDPS in the reference's order (no FMA).
#include <immintrin.h>

#include "kernels/crf_rows_variants.h"

namespace ef::kernels {

namespace {
constexpr int V = kCrfRowFloats;
constexpr int K = kCrfSimplex;
// Prefetch distance (points): rows are scattered over a lattice larger than L2, but points come in
// spatial order, so the rows a few points ahead are the ones to fetch.
constexpr std::size_t kPrefetch = 4;

void slice(const float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points, float* out) {
  for (std::size_t p = 0; p < points; ++p) {
    if (p + kPrefetch < points)
      for (int k = 0; k < K; ++k) _mm_prefetch(reinterpret_cast<const char*>(rows + std::size_t(vertices[(p + kPrefetch) * K + k]) * V), _MM_HINT_T0);
    const uint32_t* v = vertices + p * K;
    const uint16_t* w = weights + p * K;
    __m512 acc = _mm512_setzero_ps();
    for (int k = 0; k < K; ++k)
      acc = _mm512_add_ps(acc, _mm512_mul_ps(_mm512_set1_ps(float(w[k])), _mm512_loadu_ps(rows + std::size_t(v[k]) * V)));
    _mm512_storeu_ps(out + p * V, acc);
  }
}

void splat(float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points, const float* in) {
  for (std::size_t p = 0; p < points; ++p) {
    if (p + kPrefetch < points)
      for (int k = 0; k < K; ++k) _mm_prefetch(reinterpret_cast<const char*>(rows + std::size_t(vertices[(p + kPrefetch) * K + k]) * V), _MM_HINT_T0);
    const uint32_t* v = vertices + p * K;
    const uint16_t* w = weights + p * K;
    const __m512 x = _mm512_loadu_ps(in + p * V);
    for (int k = 0; k < K; ++k) {
      float* r = rows + std::size_t(v[k]) * V;
      _mm512_storeu_ps(r, _mm512_add_ps(_mm512_loadu_ps(r), _mm512_mul_ps(_mm512_set1_ps(float(w[k])), x)));
    }
  }
}

void blur(const float* in, float* out, const uint32_t* neighbours, std::size_t begin, std::size_t end) {
  const __m512 half = _mm512_set1_ps(0.5f), quarter = _mm512_set1_ps(0.25f);
  for (std::size_t v = begin; v < end; ++v) {
    const __m512 m = _mm512_loadu_ps(in + std::size_t(neighbours[2 * v]) * V);
    const __m512 p = _mm512_loadu_ps(in + std::size_t(neighbours[2 * v + 1]) * V);
    const __m512 c = _mm512_loadu_ps(in + v * V);
    _mm512_storeu_ps(out + v * V, _mm512_add_ps(_mm512_mul_ps(half, c), _mm512_mul_ps(quarter, _mm512_add_ps(m, p))));
  }
}
}  // namespace

const CrfRowsKernel crf_rows__avx512vnni = {&slice, &splat, &blur};

}  // namespace ef::kernels
