#include "platform/cpu/cpu_features.h"

#include <cstdlib>
#include <cstdio>

#if defined(__x86_64__) || defined(_M_X64)
#include <cpuid.h>
#elif defined(__aarch64__)
#include <sys/auxv.h>
#ifndef HWCAP_ASIMDDP
#define HWCAP_ASIMDDP (1 << 20)  // Linux uapi value; older headers lack the name
#endif
#endif

namespace ef {

namespace {

#if defined(__x86_64__) || defined(_M_X64)
unsigned long long xgetbv0() {
  unsigned eax, edx;
  __asm__ volatile("xgetbv" : "=a"(eax), "=d"(edx) : "c"(0));
  return (static_cast<unsigned long long>(edx) << 32) | eax;
}

CpuFeatures detect() {
  CpuFeatures f;
  unsigned a, b, c, d;
  if (!__get_cpuid(1, &a, &b, &c, &d)) return f;
  f.sse41 = (c & bit_SSE4_1) != 0;
  const bool osxsave = (c & bit_OSXSAVE) != 0;
  const bool fma = (c & bit_FMA) != 0;
  const unsigned long long xcr0 = osxsave ? xgetbv0() : 0;
  const bool os_avx = (xcr0 & 0x6) == 0x6;            // XMM and YMM state
  const bool os_avx512 = (xcr0 & 0xE6) == 0xE6;       // + opmask, ZMM_Hi256, Hi16_ZMM
  const unsigned max_leaf = __get_cpuid_max(0, nullptr);
  unsigned b7 = 0, c7 = 0, d7 = 0, a7 = 0;
  if (max_leaf >= 7) __cpuid_count(7, 0, a7, b7, c7, d7);  // beyond the maximum leaf CPUID returns junk
  const bool avx2 = (b7 & bit_AVX2) != 0 && (b7 & bit_BMI2) != 0 && fma;
  f.avx2 = os_avx && avx2;
  const bool avx512 = (b7 & bit_AVX512F) && (b7 & bit_AVX512BW) && (b7 & bit_AVX512DQ) && (b7 & bit_AVX512VL);
  const bool vnni512 = (c7 & (1u << 11)) != 0;  // AVX512_VNNI
  f.avx512vnni = f.avx2 && os_avx512 && avx512 && vnni512;
  unsigned a71 = 0, b71 = 0, c71 = 0, d71 = 0;
  if (max_leaf >= 7 && a7 >= 1) __cpuid_count(7, 1, a71, b71, c71, d71);  // a7: highest sub-leaf of leaf 7
  f.avxvnni = f.avx2 && (a71 & (1u << 4)) != 0;  // AVX_VNNI
  return f;
}
#elif defined(__aarch64__)
CpuFeatures detect() {
  CpuFeatures f;
  f.neon = true;  // mandatory on AArch64
  f.neondot = (getauxval(AT_HWCAP) & HWCAP_ASIMDDP) != 0;
  return f;
}
#else
CpuFeatures detect() { return CpuFeatures{}; }
#endif

}  // namespace

std::string CpuFeatures::describe() const {
  std::string s;
  auto add = [&](bool on, const char* name) {
    if (!on) return;
    if (!s.empty()) s += ' ';
    s += name;
  };
  add(avx512vnni, "avx512vnni");
  add(avxvnni, "avxvnni");
  add(avx2, "avx2");
  add(sse41, "sse41");
  add(neondot, "neondot");
  add(neon, "neon");
  if (!s.empty()) s += ' ';
  s += "scalar";
  return s;
}

bool cap_cpu_features(CpuFeatures& f, const std::string& isa) {
  // Levels, lowest first, one chain per architecture; a cap keeps what is at or below the named
  // level. The other architecture's features are not below it, so they are cleared too.
  const bool x86 = isa == "sse41" || isa == "avx2" || isa == "avxvnni" || isa == "avx512vnni";
  const bool arm = isa == "neon" || isa == "neondot";
  if (isa == "scalar") {
    f = CpuFeatures{};
  } else if (x86) {
    f.neon = f.neondot = false;
    if (isa == "sse41") f.avx2 = f.avxvnni = f.avx512vnni = false;
    if (isa == "avx2") f.avxvnni = f.avx512vnni = false;
    if (isa == "avxvnni") f.avx512vnni = false;
  } else if (arm) {
    f.sse41 = f.avx2 = f.avxvnni = f.avx512vnni = false;
    if (isa == "neon") f.neondot = false;
  } else {
    return false;
  }
  return true;
}

const CpuFeatures& detected_cpu_features() {
  static const CpuFeatures f = detect();
  return f;
}

const CpuFeatures& cpu_features() {
  static const CpuFeatures f = [] {
    CpuFeatures capped = detected_cpu_features();
    if (const char* isa = std::getenv("EF_ISA"); isa && *isa) {
      if (!cap_cpu_features(capped, isa))
        std::fprintf(stderr, "edgefusion: warning: EF_ISA=%s is not a known ISA name; ignored\n", isa);
    }
    return capped;
  }();
  return f;
}

}  // namespace ef
