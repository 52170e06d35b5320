// The SSE4.1 int8 peak loop (bench/nn_peak.h), in the legacy (non-VEX) encoding that SSE4.1 code
// compiles to: the two-operand pmaddwd overwrites its input, so each product needs a register copy.
#include "bench/nn_peak.h"

namespace ef::bench {

// One multiply-accumulate into `acc`: xmm14 = xmm13; xmm14 = madd(xmm14, xmm12); acc += xmm14.
#define EF_MADD(acc) "movdqa %%xmm13, %%xmm14\n\tpmaddwd %%xmm12, %%xmm14\n\tpaddd %%xmm14, %%" acc "\n\t"

int32_t peak_madd_epi16__sse41(int64_t iters) {
  if (iters <= 0) return 0;
  int64_t n = iters;
  __asm__ volatile(
      "pcmpeqd %%xmm12, %%xmm12\n\t"
      "pcmpeqd %%xmm13, %%xmm13\n\t"
      "1:\n\t"
      EF_MADD("xmm0") EF_MADD("xmm1") EF_MADD("xmm2") EF_MADD("xmm3") EF_MADD("xmm4") EF_MADD("xmm5")
      EF_MADD("xmm6") EF_MADD("xmm7") EF_MADD("xmm8") EF_MADD("xmm9") EF_MADD("xmm10") EF_MADD("xmm11")
      "dec %0\n\t"
      "jnz 1b\n\t"
      : "+r"(n)
      :
      : "cc", "xmm0", "xmm1", "xmm2", "xmm3", "xmm4", "xmm5", "xmm6", "xmm7", "xmm8", "xmm9", "xmm10", "xmm11",
        "xmm12", "xmm13", "xmm14");
  return int32_t(n);
}

#undef EF_MADD

}  // namespace ef::bench
