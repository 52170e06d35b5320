// Kernel variants and run-time dispatch, shared by every kernel family.
//
// Naming grammar: `<kernel>_ref` is the scalar reference (the specification) and
// `<kernel>__<isa>` a SIMD variant; each variant lives in its own file named after it, and
// cmake/isa.cmake gives that file its compile flags from the suffix. The suffix names the ISA
// *level* a file is compiled for and that the CPU must have at run time:
//   sse41       x86-64 baseline (SSE4.1)
//   avx2        AVX2 + FMA + BMI2
//   avxvnni     AVX2 level + AVX-VNNI (VEX VPDPBUSD on ymm)
//   avx512vnni  AVX-512 level: F, BW, DQ, VL and VNNI (our detection only reports them together,
//               so a kernel that needs only AVX-512 F/BW is still named __avx512vnni)
//   neon        AArch64 baseline (Advanced SIMD)
//   neondot     ARMv8.2 dot product (SDOT/UDOT)
//
// "One list, used three times": each family has a `<kernel>.inc` with one EF_KERNEL_VARIANT(fn, isa)
// line per variant, lowest ISA first. `<kernel>_variants.h` expands it into declarations and a
// table; the dispatcher, the tests (tests/kernels/) and the benchmark (bench/kernels.cpp) all use that
// table, so adding a variant is one line in the .inc plus its file.
//
// Rule for ISA files: they must not define or instantiate inline functions with external linkage
// (including std:: templates such as std::min) - the linker keeps one copy of each, and if it keeps the
// AVX-512 one the baseline code calling it dies with SIGILL on older CPUs. Helpers in ISA files are
// `static`; tails call the `_ref` function, which is compiled for the baseline.
#pragma once

#include <cstddef>

#include "platform/cpu/cpu_features.h"

namespace ef::kernels {

// The ISA level a variant needs (the suffix of its name).
enum class Isa { scalar, sse41, avx2, avxvnni, avx512vnni, neon, neondot };

// "avx2" etc.; "scalar" for the reference.
const char* isa_name(Isa isa);

// True when `features` allow a variant of level `isa` to run.
bool isa_available(Isa isa, const CpuFeatures& features);

// True when the kernels may use `isa` on this CPU: detection capped by EF_ISA (cpu_features()).
inline bool isa_available(Isa isa) { return isa_available(isa, cpu_features()); }

// One row of a family's table. `Fn` is the family's function-pointer type.
template <class Fn>
struct KernelVariant {
  const char* name;  // e.g. "dot_i8__avx2"
  Isa isa;
  Fn fn;
};

// The best variant that `features` allow: the last available row (tables are ordered lowest ISA
// first, and row 0 is always the scalar reference, so a result always exists).
template <class Fn, std::size_t N>
const KernelVariant<Fn>& best_variant(const KernelVariant<Fn> (&table)[N], const CpuFeatures& features) {
  std::size_t best = 0;
  for (std::size_t i = 0; i < N; ++i)
    if (isa_available(table[i].isa, features)) best = i;
  return table[best];
}

}  // namespace ef::kernels
