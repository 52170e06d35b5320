// concat_i8 at the AVX2 level: per input and pixel, its channel run copied (same quantisation) or
// requantised in 8-lane float32 quarters, 32 channels per step, then the SSE4.1 blocks (16, 8, 4),
// the last block overlapping the previous one; the loop nest is nn/concat_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/concat_i8_simd.h"

namespace ef::nn {

void concat_i8__avx2(const ConcatArgs& a) { concat_channels<ChannelBlocks<Y32, X16, X8, X4>>(a); }

}  // namespace ef::nn
