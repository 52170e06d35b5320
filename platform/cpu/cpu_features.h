// CPU features detected at run time, for choosing SIMD kernels (src/kernels/dispatch.h).
//
// x86-64: the build baseline is SSE4.1; AVX2, AVX-VNNI and AVX-512 VNNI are detected with CPUID
// and XGETBV (the OS must save the wider registers). AArch64: NEON is the baseline; the dot-product
// instructions (SDOT/UDOT) are detected from getauxval(AT_HWCAP).
//
// EF_ISA=<name> in the environment caps the choice for benchmarking and debugging: "scalar",
// "sse41", "avx2", "avxvnni", "avx512vnni", "neon", "neondot". A cap never enables a feature the
// CPU lacks. Thread-safe: detection runs once.
#pragma once

#include <string>

namespace ef {

struct CpuFeatures {
  bool sse41 = false;
  bool avx2 = false;        // with FMA and BMI2
  bool avxvnni = false;     // AVX-VNNI (VEX-encoded VPDPBUSD on 256-bit registers)
  bool avx512vnni = false;  // AVX-512 F, BW, DQ, VL and VNNI
  bool neon = false;
  bool neondot = false;     // ARMv8.2 dot product

  // "avx512vnni avx2 sse41" style list of what is available, best first.
  std::string describe() const;
};

// What the CPU supports, before any EF_ISA cap.
const CpuFeatures& detected_cpu_features();

// What kernels may use: detected features capped by EF_ISA (read once, at first call).
const CpuFeatures& cpu_features();

// Caps `features` at the named ISA level; returns false for an unknown name.
bool cap_cpu_features(CpuFeatures& features, const std::string& isa_name);

}  // namespace ef
