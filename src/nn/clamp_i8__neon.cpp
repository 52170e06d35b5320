// clamp_i8 on NEON: the tensor as one flat run, 16 bytes per SMAX/SMIN q, then 8-byte blocks, the
// last block overlapping the previous one; the loop is nn/clamp_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/clamp_i8_simd.h"

namespace ef::nn {

void clamp_i8__neon(const ClampArgs& a) { clamp_flat<ChannelBlocks<N16, N8>>(a); }

}  // namespace ef::nn
