// Test twins of conv_i8 variants that the lab's CPUs cannot run: the variant's source compiled a
// second time with another encoding of the same instructions, which those CPUs do run. A twin is
// in no dispatch table; tests run it against the reference in place of the variant.
#pragma once

#include "kernels/variants.h"
#include "nn/conv_kernels.h"

namespace ef::nn {

#if defined(__x86_64__)
// conv_i8__avxvnni (VEX VPDPBUSD on ymm) built with EVEX VPDPBUSD on ymm: needs AVX-512 VNNI.
extern const ConvKernel conv_i8_vnni256_twin__avx512vnni;

struct ConvTwin {
  const char* twin_of;  // the table row whose source it shares
  kernels::KernelVariant<ConvKernelPtr> twin;
};

inline constexpr ConvTwin kConvI8Twins[] = {
    {"conv_i8__avxvnni",
     {"conv_i8_vnni256_twin__avx512vnni", kernels::Isa::avx512vnni, &conv_i8_vnni256_twin__avx512vnni}},
};
#endif

}  // namespace ef::nn
