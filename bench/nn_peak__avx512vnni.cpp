// The AVX-512 int8 peak loops (bench/nn_peak.h). zmm12 and zmm13 are the operands, zmm14 and zmm15
// take products in turn (register renaming makes the reuse free), zmm0..zmm11 accumulate.
#include "bench/nn_peak.h"

namespace ef::bench {

#define EF_CLOBBERS                                                                                            \
  "cc", "xmm0", "xmm1", "xmm2", "xmm3", "xmm4", "xmm5", "xmm6", "xmm7", "xmm8", "xmm9", "xmm10", "xmm11",       \
      "xmm12", "xmm13", "xmm14", "xmm15"

// vpdpbusd zmm: 64 uint8 x int8 products summed in fours into 16 int32 accumulators (64 MACs).
#define EF_DP(acc) "vpdpbusd %%zmm13, %%zmm12, %%" acc "\n\t"

int32_t peak_dpbusd__avx512vnni(int64_t iters) {
  if (iters <= 0) return 0;
  int64_t n = iters;
  __asm__ volatile(
      "vpternlogd $0xff, %%zmm12, %%zmm12, %%zmm12\n\t"
      "vpternlogd $0xff, %%zmm13, %%zmm13, %%zmm13\n\t"
      "1:\n\t"
      EF_DP("zmm0") EF_DP("zmm1") EF_DP("zmm2") EF_DP("zmm3") EF_DP("zmm4") EF_DP("zmm5")
      EF_DP("zmm6") EF_DP("zmm7") EF_DP("zmm8") EF_DP("zmm9") EF_DP("zmm10") EF_DP("zmm11")
      "dec %0\n\t"
      "jnz 1b\n\t"
      "vzeroupper\n\t"
      : "+r"(n)
      :
      : EF_CLOBBERS);
  return int32_t(n);
}

// vpmaddwd zmm: 32 int16 x int16 products summed in pairs (32 MACs), plus vpaddd: the multiply-accumulate
// of XNNPACK's AVX-512 (avx512skx) int8 kernels.
#define EF_MADD(tmp, acc) "vpmaddwd %%zmm13, %%zmm12, %%" tmp "\n\tvpaddd %%" tmp ", %%" acc ", %%" acc "\n\t"

int32_t peak_madd_epi16__avx512vnni(int64_t iters) {
  if (iters <= 0) return 0;
  int64_t n = iters;
  __asm__ volatile(
      "vpternlogd $0xff, %%zmm12, %%zmm12, %%zmm12\n\t"
      "vpternlogd $0xff, %%zmm13, %%zmm13, %%zmm13\n\t"
      "1:\n\t"
      EF_MADD("zmm14", "zmm0") EF_MADD("zmm15", "zmm1") EF_MADD("zmm14", "zmm2") EF_MADD("zmm15", "zmm3")
      EF_MADD("zmm14", "zmm4") EF_MADD("zmm15", "zmm5") EF_MADD("zmm14", "zmm6") EF_MADD("zmm15", "zmm7")
      EF_MADD("zmm14", "zmm8") EF_MADD("zmm15", "zmm9") EF_MADD("zmm14", "zmm10") EF_MADD("zmm15", "zmm11")
      "dec %0\n\t"
      "jnz 1b\n\t"
      "vzeroupper\n\t"
      : "+r"(n)
      :
      : EF_CLOBBERS);
  return int32_t(n);
}

#undef EF_MADD
#undef EF_DP
#undef EF_CLOBBERS

}  // namespace ef::bench
