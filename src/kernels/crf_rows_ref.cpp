// Scalar reference of crf_rows: the specification every SIMD variant must match bit for bit. Per
// element: slice 0 + w0 r0, then + w_k r_k for k = 1..6 (each product rounded, then the sum); splat
// row + w in; blur (0.5 c) + (0.25 (m + p)).
#include "kernels/crf_rows_variants.h"

namespace ef::kernels {

namespace {
constexpr int V = kCrfRowFloats;
constexpr int K = kCrfSimplex;

void slice_ref(const float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points, float* out) {
  for (std::size_t p = 0; p < points; ++p) {
    float acc[V] = {};
    for (int k = 0; k < K; ++k) {
      const float* r = rows + std::size_t(vertices[p * K + k]) * V;
      const float w = float(weights[p * K + k]);
      for (int c = 0; c < V; ++c) acc[c] = acc[c] + w * r[c];
    }
    for (int c = 0; c < V; ++c) out[p * V + c] = acc[c];
  }
}

void splat_ref(float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points, const float* in) {
  for (std::size_t p = 0; p < points; ++p)
    for (int k = 0; k < K; ++k) {
      float* r = rows + std::size_t(vertices[p * K + k]) * V;
      const float w = float(weights[p * K + k]);
      for (int c = 0; c < V; ++c) r[c] = r[c] + w * in[p * V + c];
    }
}

void blur_ref(const float* in, float* out, const uint32_t* neighbours, std::size_t begin, std::size_t end) {
  for (std::size_t v = begin; v < end; ++v) {
    const float* m = in + std::size_t(neighbours[2 * v]) * V;
    const float* p = in + std::size_t(neighbours[2 * v + 1]) * V;
    const float* c = in + v * V;
    for (int e = 0; e < V; ++e) out[v * V + e] = 0.5f * c[e] + 0.25f * (m[e] + p[e]);
  }
}
}  // namespace

const CrfRowsKernel crf_rows_ref = {&slice_ref, &splat_ref, &blur_ref};

}  // namespace ef::kernels
