// avgpool_i8 at the AVX2 level: NHWC, vectorised over channels: int32 window sums of 32 channels in
// four ymm, then the SSE4.1 blocks (16, 8, 4), and the float32 requantisation; the last block overlaps
// the previous one; the loop nest is nn/avgpool_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/avgpool_i8_simd.h"

namespace ef::nn {

void avgpool_i8__avx2(const PoolArgs& a) { avgpool_rows<ChannelBlocks<Y32, X16, X8, X4>>(a); }

}  // namespace ef::nn
