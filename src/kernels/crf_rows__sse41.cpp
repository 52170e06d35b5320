// crf_rows for SSE4.1 (the x86-64 baseline): one 16-float row is four xmm. Separate MULPS and ADDPS
// in the reference's order.
#include <smmintrin.h>

#include "kernels/crf_rows_variants.h"

namespace ef::kernels {

namespace {
constexpr int V = kCrfRowFloats;
constexpr int K = kCrfSimplex;
// Prefetch distance (points): rows are scattered over a lattice larger than L2, but points come in
// spatial order, so the rows a few points ahead are the ones to fetch.
constexpr std::size_t kPrefetch = 4;

void prefetch_rows(const float* rows, const uint32_t* v) {
  for (int k = 0; k < K; ++k) _mm_prefetch(reinterpret_cast<const char*>(rows + std::size_t(v[k]) * V), _MM_HINT_T0);
}

void slice(const float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points, float* out) {
  for (std::size_t p = 0; p < points; ++p) {
    if (p + kPrefetch < points) prefetch_rows(rows, vertices + (p + kPrefetch) * K);
    const uint32_t* v = vertices + p * K;
    const uint16_t* w = weights + p * K;
    __m128 a0 = _mm_setzero_ps(), a1 = _mm_setzero_ps(), a2 = _mm_setzero_ps(), a3 = _mm_setzero_ps();
    for (int k = 0; k < K; ++k) {
      const float* r = rows + std::size_t(v[k]) * V;
      const __m128 wk = _mm_set1_ps(float(w[k]));
      a0 = _mm_add_ps(a0, _mm_mul_ps(wk, _mm_loadu_ps(r)));
      a1 = _mm_add_ps(a1, _mm_mul_ps(wk, _mm_loadu_ps(r + 4)));
      a2 = _mm_add_ps(a2, _mm_mul_ps(wk, _mm_loadu_ps(r + 8)));
      a3 = _mm_add_ps(a3, _mm_mul_ps(wk, _mm_loadu_ps(r + 12)));
    }
    _mm_storeu_ps(out + p * V, a0);
    _mm_storeu_ps(out + p * V + 4, a1);
    _mm_storeu_ps(out + p * V + 8, a2);
    _mm_storeu_ps(out + p * V + 12, a3);
  }
}

void splat(float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points, const float* in) {
  for (std::size_t p = 0; p < points; ++p) {
    if (p + kPrefetch < points) prefetch_rows(rows, vertices + (p + kPrefetch) * K);
    const uint32_t* v = vertices + p * K;
    const uint16_t* w = weights + p * K;
    const __m128 x0 = _mm_loadu_ps(in + p * V), x1 = _mm_loadu_ps(in + p * V + 4);
    const __m128 x2 = _mm_loadu_ps(in + p * V + 8), x3 = _mm_loadu_ps(in + p * V + 12);
    for (int k = 0; k < K; ++k) {
      float* r = rows + std::size_t(v[k]) * V;
      const __m128 wk = _mm_set1_ps(float(w[k]));
      _mm_storeu_ps(r, _mm_add_ps(_mm_loadu_ps(r), _mm_mul_ps(wk, x0)));
      _mm_storeu_ps(r + 4, _mm_add_ps(_mm_loadu_ps(r + 4), _mm_mul_ps(wk, x1)));
      _mm_storeu_ps(r + 8, _mm_add_ps(_mm_loadu_ps(r + 8), _mm_mul_ps(wk, x2)));
      _mm_storeu_ps(r + 12, _mm_add_ps(_mm_loadu_ps(r + 12), _mm_mul_ps(wk, x3)));
    }
  }
}

void blur(const float* in, float* out, const uint32_t* neighbours, std::size_t begin, std::size_t end) {
  const __m128 half = _mm_set1_ps(0.5f), quarter = _mm_set1_ps(0.25f);
  for (std::size_t v = begin; v < end; ++v) {
    const float* m = in + std::size_t(neighbours[2 * v]) * V;
    const float* p = in + std::size_t(neighbours[2 * v + 1]) * V;
    const float* c = in + v * V;
    for (int h = 0; h < V; h += 4)
      _mm_storeu_ps(out + v * V + h, _mm_add_ps(_mm_mul_ps(half, _mm_loadu_ps(c + h)),
                                                _mm_mul_ps(quarter, _mm_add_ps(_mm_loadu_ps(m + h), _mm_loadu_ps(p + h)))));
  }
}
}  // namespace

const CrfRowsKernel crf_rows__sse41 = {&slice, &splat, &blur};

}  // namespace ef::kernels
