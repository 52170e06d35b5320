// clamp_i8 at the AVX2 level: the tensor as one flat run, 32 bytes per VPMAXSB/VPMINSB ymm, then the
// SSE4.1 blocks (16, 8, 4 bytes), the last block overlapping the previous one; the loop is
// nn/clamp_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/clamp_i8_simd.h"

namespace ef::nn {

void clamp_i8__avx2(const ClampArgs& a) { clamp_flat<ChannelBlocks<Y32, X16, X8, X4>>(a); }

}  // namespace ef::nn
