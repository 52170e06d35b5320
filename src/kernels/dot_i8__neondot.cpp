// dot_i8 with the ARMv8.2 dot-product instructions (SDOT: four signed int8 products summed into each
// int32 lane, exact). Compiled with -march=armv8.2-a+dotprod (cmake/isa.cmake); chosen only when
// getauxval(AT_HWCAP) reports ASIMDDP. 32 elements per step, two accumulators.
#include <arm_neon.h>

#include "kernels/dot_i8_variants.h"

namespace ef::kernels {

int32_t dot_i8__neondot(const int8_t* a, const int8_t* b, std::size_t n) {
  int32x4_t acc0 = vdupq_n_s32(0);
  int32x4_t acc1 = vdupq_n_s32(0);
  std::size_t i = 0;
  for (; i + 32 <= n; i += 32) {
    acc0 = vdotq_s32(acc0, vld1q_s8(a + i), vld1q_s8(b + i));
    acc1 = vdotq_s32(acc1, vld1q_s8(a + i + 16), vld1q_s8(b + i + 16));
  }
  if (i + 16 <= n) {
    acc0 = vdotq_s32(acc0, vld1q_s8(a + i), vld1q_s8(b + i));
    i += 16;
  }
  const int32_t simd = vaddvq_s32(vaddq_s32(acc0, acc1));
  return wrapping_add_i32(simd, dot_i8_ref(a + i, b + i, n - i));
}

}  // namespace ef::kernels
