// Every variant of track_rows (internal: the dispatcher, tests and benchmarks use it).
// Contract of each variant: that of ef::kernels::track_rows (kernels/track_rows.h), bit for bit.
//
// Files of this family are compiled with floating-point contraction off (kernels/fp_contract_off.h
// in each file, as well as -ffp-contract=off on the library): a fused multiply-add would round differently from the
// reference's separate multiply and add.
#pragma once

#include <cstddef>

#include "kernels/track_rows.h"
#include "kernels/variants.h"

namespace ef::kernels {

using TrackRowsFn = void (*)(const TrackRowsParams& params, const float* cur_vertex, const float* cur_normal,
                             const float* cur_intensity, std::size_t n, float* icp_rows, float* rgb_rows,
                             std::size_t stride, TrackRowsCounts* counts);

#define EF_KERNEL_VARIANT(fn, isa)                                                                                     \
  void fn(const TrackRowsParams& params, const float* cur_vertex, const float* cur_normal, const float* cur_intensity, \
          std::size_t n, float* icp_rows, float* rgb_rows, std::size_t stride, TrackRowsCounts* counts);
#include "kernels/track_rows.inc"
#undef EF_KERNEL_VARIANT

inline constexpr KernelVariant<TrackRowsFn> kTrackRowsVariants[] = {
#define EF_KERNEL_VARIANT(fn, isa) {#fn, Isa::isa, &fn},
#include "kernels/track_rows.inc"
#undef EF_KERNEL_VARIANT
};

// Name of the variant track_rows() dispatches to on this CPU.
const char* track_rows_selected();

}  // namespace ef::kernels
