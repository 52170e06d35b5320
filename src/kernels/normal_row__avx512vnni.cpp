// normal_row at the AVX-512 level: 16 pixels per step in zmm registers, masks in k registers
// (AVX-512 F; named __avx512vnni after the ISA level our detection reports, see kernels/variants.h).
// The 48 floats of 16 pixels are three loads; two VPERMT2PS gather each component (the first from
// the first two loads, the second adds the third), and the same in reverse to store.
#include <immintrin.h>

#include <cstdint>

#include "kernels/f32_ops_avx512.h"
#include "kernels/normal_row_simd.h"

namespace ef::kernels {

namespace {

// Index tables of the permutes. Gathering component k: lane i takes float g = 3 i + k of the 48,
// first from loads a, b (g < 32: index g) and then from load c (index 16 + g - 32, else keep lane
// i). Scattering: float g of store s (g = 16 s + e) is component g % 3 of pixel g / 3, taken from x
// and y first, then z. Computed by the compiler (a constexpr object: no start-up code compiled for
// AVX-512, which would run on every CPU).
struct Tables {
  int32_t gather_ab[3][16]{}, gather_c[3][16]{}, scatter_xy[3][16]{}, scatter_z[3][16]{};
  constexpr Tables() {
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < 16; ++i) {
        const int g = 3 * i + k;
        gather_ab[k][i] = g < 32 ? g : 0;
        gather_c[k][i] = g < 32 ? i : 16 + g - 32;
      }
    for (int s = 0; s < 3; ++s)
      for (int e = 0; e < 16; ++e) {
        const int g = 16 * s + e, pixel = g / 3, comp = g % 3;
        scatter_xy[s][e] = comp == 0 ? pixel : comp == 1 ? 16 + pixel : 0;
        scatter_z[s][e] = comp == 2 ? 16 + pixel : e;
      }
  }
};
constexpr Tables kTables;

struct Avx512 : F32Avx512 {
  static __m512i idx(const int32_t* t) { return _mm512_loadu_si512(t); }
  static void load3(const float* p, F& x, F& y, F& z) {
    const F a = _mm512_loadu_ps(p), b = _mm512_loadu_ps(p + 16), c = _mm512_loadu_ps(p + 32);
    F* out[3] = {&x, &y, &z};
    for (int k = 0; k < 3; ++k) {
      const F ab = _mm512_permutex2var_ps(a, idx(kTables.gather_ab[k]), b);
      *out[k] = _mm512_permutex2var_ps(ab, idx(kTables.gather_c[k]), c);
    }
  }
  static void store3(float* p, F x, F y, F z) {
    for (int s = 0; s < 3; ++s) {
      const F xy = _mm512_permutex2var_ps(x, idx(kTables.scatter_xy[s]), y);
      _mm512_storeu_ps(p + 16 * s, _mm512_permutex2var_ps(xy, idx(kTables.scatter_z[s]), z));
    }
  }
};
}  // namespace

void normal_row__avx512vnni(const NormalRow& r, int x_begin, int x_end, float* normal) {
  normal_row_simd<Avx512>(r, x_begin, x_end, normal);
}

}  // namespace ef::kernels
