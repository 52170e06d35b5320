// The AVX-VNNI int8 peak loop (bench/nn_peak.h): VEX-encoded vpdpbusd on ymm ("%{vex%}" is "{vex}" in
// an asm template). ymm12 and ymm13 are the operands, ymm0..ymm11 accumulate.
#include "bench/nn_peak.h"

namespace ef::bench {

#define EF_DP(acc) "%{vex%} vpdpbusd %%ymm13, %%ymm12, %%" acc "\n\t"

// vpdpbusd: 32 uint8 x int8 products summed in fours into 8 int32 accumulators (32 MACs).
int32_t peak_dpbusd__avxvnni(int64_t iters) {
  if (iters <= 0) return 0;
  int64_t n = iters;
  __asm__ volatile(
      "vpcmpeqd %%ymm12, %%ymm12, %%ymm12\n\t"
      "vpcmpeqd %%ymm13, %%ymm13, %%ymm13\n\t"
      "1:\n\t"
      EF_DP("ymm0") EF_DP("ymm1") EF_DP("ymm2") EF_DP("ymm3") EF_DP("ymm4") EF_DP("ymm5")
      EF_DP("ymm6") EF_DP("ymm7") EF_DP("ymm8") EF_DP("ymm9") EF_DP("ymm10") EF_DP("ymm11")
      "dec %0\n\t"
      "jnz 1b\n\t"
      "vzeroupper\n\t"
      : "+r"(n)
      :
      : "cc", "xmm0", "xmm1", "xmm2", "xmm3", "xmm4", "xmm5", "xmm6", "xmm7", "xmm8", "xmm9", "xmm10", "xmm11",
        "xmm12", "xmm13");
  return int32_t(n);
}

#undef EF_DP

}  // namespace ef::bench
