// The AVX2 int8 peak loops (bench/nn_peak.h). ymm12 and ymm13 are the operands, ymm14 and ymm15 take
// the products in turn (register renaming makes the reuse free), ymm0..ymm11 accumulate.
#include "bench/nn_peak.h"

namespace ef::bench {

#define EF_STEP(mul, add, tmp, acc) mul " %%ymm13, %%ymm12, %%" tmp "\n\t" add " %%" tmp ", %%" acc ", %%" acc "\n\t"
#define EF_TWELVE(mul, add)                                                                                    \
  EF_STEP(mul, add, "ymm14", "ymm0") EF_STEP(mul, add, "ymm15", "ymm1") EF_STEP(mul, add, "ymm14", "ymm2")    \
  EF_STEP(mul, add, "ymm15", "ymm3") EF_STEP(mul, add, "ymm14", "ymm4") EF_STEP(mul, add, "ymm15", "ymm5")    \
  EF_STEP(mul, add, "ymm14", "ymm6") EF_STEP(mul, add, "ymm15", "ymm7") EF_STEP(mul, add, "ymm14", "ymm8")    \
  EF_STEP(mul, add, "ymm15", "ymm9") EF_STEP(mul, add, "ymm14", "ymm10") EF_STEP(mul, add, "ymm15", "ymm11")
#define EF_CLOBBERS                                                                                            \
  "cc", "xmm0", "xmm1", "xmm2", "xmm3", "xmm4", "xmm5", "xmm6", "xmm7", "xmm8", "xmm9", "xmm10", "xmm11",       \
      "xmm12", "xmm13", "xmm14", "xmm15"

// vpmaddwd: 16 int16 x int16 products summed in pairs into 8 int32 (16 MACs), plus vpaddd.
int32_t peak_madd_epi16__avx2(int64_t iters) {
  if (iters <= 0) return 0;
  int64_t n = iters;
  __asm__ volatile(
      "vpcmpeqd %%ymm12, %%ymm12, %%ymm12\n\t"
      "vpcmpeqd %%ymm13, %%ymm13, %%ymm13\n\t"
      "1:\n\t"
      EF_TWELVE("vpmaddwd", "vpaddd")
      "dec %0\n\t"
      "jnz 1b\n\t"
      "vzeroupper\n\t"
      : "+r"(n)
      :
      : EF_CLOBBERS);
  return int32_t(n);
}

// vpmaddubsw: 32 uint8 x int8 products summed in pairs into 16 int16 (32 MACs), plus vpaddw. A
// reference only: the int16 pair sums saturate, so exact kernels cannot use it on full-range int8 data.
int32_t peak_maddubs_epi16__avx2(int64_t iters) {
  if (iters <= 0) return 0;
  int64_t n = iters;
  __asm__ volatile(
      "vpcmpeqd %%ymm12, %%ymm12, %%ymm12\n\t"
      "vpcmpeqd %%ymm13, %%ymm13, %%ymm13\n\t"
      "1:\n\t"
      EF_TWELVE("vpmaddubsw", "vpaddw")
      "dec %0\n\t"
      "jnz 1b\n\t"
      "vzeroupper\n\t"
      : "+r"(n)
      :
      : EF_CLOBBERS);
  return int32_t(n);
}

#undef EF_CLOBBERS
#undef EF_TWELVE
#undef EF_STEP

}  // namespace ef::bench
