// The NEON dot-product int8 peak loop (bench/nn_peak.h). No inline functions in ISA files
// (kernels/variants.h).
#include <arm_neon.h>

#include "bench/nn_peak.h"

namespace ef::bench {

// sdot: 16 int8 x int8 products summed in fours into 4 int32 accumulators (16 MACs). The accumulators
// differ, so nothing can be shared; the empty asm (no instruction) keeps the inputs opaque.
int32_t peak_sdot__neondot(int64_t iters) {
  int8x16_t a = vdupq_n_s8(3), b = vdupq_n_s8(5);
  // Distinct starting values: identical chains could be merged into one by the compiler.
  int32x4_t c0 = vdupq_n_s32(0), c1 = vdupq_n_s32(1), c2 = vdupq_n_s32(2), c3 = vdupq_n_s32(3), c4 = vdupq_n_s32(4), c5 = vdupq_n_s32(5);
  int32x4_t c6 = vdupq_n_s32(6), c7 = vdupq_n_s32(7), c8 = vdupq_n_s32(8), c9 = vdupq_n_s32(9), c10 = vdupq_n_s32(10), c11 = vdupq_n_s32(11);
  for (int64_t i = 0; i < iters; ++i) {
    __asm__ volatile("" : "+w"(a), "+w"(b));
    c0 = vdotq_s32(c0, a, b);
    c1 = vdotq_s32(c1, a, b);
    c2 = vdotq_s32(c2, a, b);
    c3 = vdotq_s32(c3, a, b);
    c4 = vdotq_s32(c4, a, b);
    c5 = vdotq_s32(c5, a, b);
    c6 = vdotq_s32(c6, a, b);
    c7 = vdotq_s32(c7, a, b);
    c8 = vdotq_s32(c8, a, b);
    c9 = vdotq_s32(c9, a, b);
    c10 = vdotq_s32(c10, a, b);
    c11 = vdotq_s32(c11, a, b);
  }
  const int32x4_t s = vaddq_s32(vaddq_s32(vaddq_s32(vaddq_s32(c0, c1), vaddq_s32(c2, c3)),
                                          vaddq_s32(vaddq_s32(c4, c5), vaddq_s32(c6, c7))),
                                vaddq_s32(vaddq_s32(c8, c9), vaddq_s32(c10, c11)));
  return vaddvq_s32(s);
}

}  // namespace ef::bench
