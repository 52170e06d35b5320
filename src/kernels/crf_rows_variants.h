// Every variant of crf_rows (internal: the dispatcher, tests and benchmark use it). A variant is a
// row of three functions with the contracts of crf_slice_rows, crf_splat_rows and crf_blur_rows
// (kernels/crf_rows.h); each variant file defines its row, the functions themselves are static there.
#pragma once

#include <cstddef>
#include <cstdint>

#include "kernels/crf_rows.h"
#include "kernels/variants.h"

namespace ef::kernels {

struct CrfRowsKernel {
  void (*slice)(const float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points,
                float* out);
  void (*splat)(float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points,
                const float* in);
  void (*blur)(const float* in, float* out, const uint32_t* neighbours, std::size_t begin, std::size_t end);
};
using CrfRowsKernelPtr = const CrfRowsKernel*;

#define EF_KERNEL_VARIANT(name, isa) extern const CrfRowsKernel name;
#include "kernels/crf_rows.inc"
#undef EF_KERNEL_VARIANT

inline constexpr KernelVariant<CrfRowsKernelPtr> kCrfRowsVariants[] = {
#define EF_KERNEL_VARIANT(name, isa) {#name, Isa::isa, &name},
#include "kernels/crf_rows.inc"
#undef EF_KERNEL_VARIANT
};

}  // namespace ef::kernels
