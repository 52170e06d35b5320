// The NEON int8 peak loop (bench/nn_peak.h). No inline functions in ISA files (kernels/variants.h).
#include <arm_neon.h>

#include "bench/nn_peak.h"

namespace ef::bench {

// smlal: 8 int8 x int8 products added to 8 int16 accumulators (8 MACs). The accumulators differ, so
// nothing can be shared; the empty asm (no instruction) keeps the inputs opaque.
int32_t peak_smlal__neon(int64_t iters) {
  int8x8_t a = vdup_n_s8(3), b = vdup_n_s8(5);
  // Distinct starting values: identical chains could be merged into one by the compiler.
  int16x8_t c0 = vdupq_n_s16(0), c1 = vdupq_n_s16(1), c2 = vdupq_n_s16(2), c3 = vdupq_n_s16(3), c4 = vdupq_n_s16(4), c5 = vdupq_n_s16(5);
  int16x8_t c6 = vdupq_n_s16(6), c7 = vdupq_n_s16(7), c8 = vdupq_n_s16(8), c9 = vdupq_n_s16(9), c10 = vdupq_n_s16(10), c11 = vdupq_n_s16(11);
  for (int64_t i = 0; i < iters; ++i) {
    __asm__ volatile("" : "+w"(a), "+w"(b));
    c0 = vmlal_s8(c0, a, b);
    c1 = vmlal_s8(c1, a, b);
    c2 = vmlal_s8(c2, a, b);
    c3 = vmlal_s8(c3, a, b);
    c4 = vmlal_s8(c4, a, b);
    c5 = vmlal_s8(c5, a, b);
    c6 = vmlal_s8(c6, a, b);
    c7 = vmlal_s8(c7, a, b);
    c8 = vmlal_s8(c8, a, b);
    c9 = vmlal_s8(c9, a, b);
    c10 = vmlal_s8(c10, a, b);
    c11 = vmlal_s8(c11, a, b);
  }
  const int16x8_t s = vaddq_s16(vaddq_s16(vaddq_s16(vaddq_s16(c0, c1), vaddq_s16(c2, c3)),
                                          vaddq_s16(vaddq_s16(c4, c5), vaddq_s16(c6, c7))),
                                vaddq_s16(vaddq_s16(c8, c9), vaddq_s16(c10, c11)));
  return vaddvq_s16(s);
}

}  // namespace ef::bench
