// Internal to the x86 variants of normal_row: four 3-float elements (x, y, z each, 12 consecutive
// floats) to and from three registers of x, y and z, with SSE4.1 blends and shuffles. The SSE4.1
// variant uses it for its 4 lanes and the AVX2 variant for each half of its 8. Internal linkage (an
// anonymous namespace): each ISA file compiles its own copy with its own flags (kernels/variants.h).
#pragma once

#include <smmintrin.h>

namespace ef::kernels {
namespace {

// p: a = x0 y0 z0 x1, b = y1 z1 x2 y2, c = z2 x3 y3 z3. Two blends put each component's four values
// into one register in a known order (x0 x3 x2 x1, y1 y0 y3 y2, z2 z1 z0 z3), a shuffle sorts them.
inline void load_xyz4(const float* p, __m128& x, __m128& y, __m128& z) {
  const __m128 a = _mm_loadu_ps(p), b = _mm_loadu_ps(p + 4), c = _mm_loadu_ps(p + 8);
  const __m128 mx = _mm_blend_ps(_mm_blend_ps(a, b, 0x4), c, 0x2);
  const __m128 my = _mm_blend_ps(_mm_blend_ps(a, b, 0x9), c, 0x4);
  const __m128 mz = _mm_blend_ps(_mm_blend_ps(a, b, 0x2), c, 0x9);
  x = _mm_shuffle_ps(mx, mx, _MM_SHUFFLE(1, 2, 3, 0));
  y = _mm_shuffle_ps(my, my, _MM_SHUFFLE(2, 3, 0, 1));
  z = _mm_shuffle_ps(mz, mz, _MM_SHUFFLE(3, 0, 1, 2));
}

// The inverse of load_xyz4: the same shuffles (each is its own inverse), then blends.
inline void store_xyz4(float* p, __m128 x, __m128 y, __m128 z) {
  const __m128 mx = _mm_shuffle_ps(x, x, _MM_SHUFFLE(1, 2, 3, 0));
  const __m128 my = _mm_shuffle_ps(y, y, _MM_SHUFFLE(2, 3, 0, 1));
  const __m128 mz = _mm_shuffle_ps(z, z, _MM_SHUFFLE(3, 0, 1, 2));
  _mm_storeu_ps(p, _mm_blend_ps(_mm_blend_ps(mx, my, 0x2), mz, 0x4));
  _mm_storeu_ps(p + 4, _mm_blend_ps(_mm_blend_ps(my, mz, 0x2), mx, 0x4));
  _mm_storeu_ps(p + 8, _mm_blend_ps(_mm_blend_ps(mz, mx, 0x2), my, 0x4));
}

}  // namespace
}  // namespace ef::kernels
