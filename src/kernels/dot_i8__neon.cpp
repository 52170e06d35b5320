// dot_i8 for NEON (AArch64 baseline): widening multiply to int16 (SMULL/SMULL2) and pairwise
// add-accumulate into int32 (SADALP). Each int16 product is at most 128*128 = 16384, but two of
// them can reach 32768, so products are never summed in int16. 16 elements per step.
#include <arm_neon.h>

#include "kernels/dot_i8_variants.h"

namespace ef::kernels {

int32_t dot_i8__neon(const int8_t* a, const int8_t* b, std::size_t n) {
  int32x4_t acc0 = vdupq_n_s32(0);
  int32x4_t acc1 = vdupq_n_s32(0);
  std::size_t i = 0;
  for (; i + 16 <= n; i += 16) {
    const int8x16_t va = vld1q_s8(a + i);
    const int8x16_t vb = vld1q_s8(b + i);
    acc0 = vpadalq_s16(acc0, vmull_s8(vget_low_s8(va), vget_low_s8(vb)));
    acc1 = vpadalq_s16(acc1, vmull_high_s8(va, vb));
  }
  // ADDV wraps modulo 2^32 like the lane adds.
  const int32_t simd = vaddvq_s32(vaddq_s32(acc0, acc1));
  return wrapping_add_i32(simd, dot_i8_ref(a + i, b + i, n - i));
}

}  // namespace ef::kernels
