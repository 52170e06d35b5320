// Throughput loops of the int8 multiply-accumulate instruction of each ISA level: the peak that
// bench_nn_conv measures each convolution kernel against. Each function runs `iters` iterations of
// kPeakChains independent accumulators, one multiply-accumulate per accumulator per iteration (the
// instruction plus, where it does not accumulate itself, the add that accumulates its result), so the
// loop is bound by the instructions' throughput, not their latency. The x86 loops are inline assembly
// (a compiler may merge identical chains, hoist invariant products or spill accumulators, and then it
// no longer measures the instruction); the results are discarded. The files are nn_peak__<isa>.cpp,
// compiled with that ISA's flags (cmake/isa.cmake); call a function only when
// kernels::isa_available(<isa>). Returns a value the caller stores, so that no call is dropped.
#pragma once

#include <cstdint>

namespace ef::bench {

inline constexpr int kPeakChains = 12;

#if defined(__x86_64__)
int32_t peak_madd_epi16__sse41(int64_t iters);        // pmaddwd xmm + paddd: 8 MACs
int32_t peak_madd_epi16__avx2(int64_t iters);         // vpmaddwd ymm + vpaddd: 16 MACs
int32_t peak_maddubs_epi16__avx2(int64_t iters);      // vpmaddubsw ymm + vpaddw: 32 MACs
int32_t peak_dpbusd__avxvnni(int64_t iters);          // {vex} vpdpbusd ymm: 32 MACs
int32_t peak_dpbusd__avx512vnni(int64_t iters);       // vpdpbusd zmm: 64 MACs
int32_t peak_madd_epi16__avx512vnni(int64_t iters);   // vpmaddwd zmm + vpaddd: 32 MACs
#elif defined(__aarch64__)
int32_t peak_smlal__neon(int64_t iters);              // smlal v.8h (vmlal_s8): 8 MACs
int32_t peak_sdot__neondot(int64_t iters);            // sdot v.4s (vdotq_s32): 16 MACs
#endif

}  // namespace ef::bench
