// avgpool_i8 on NEON: NHWC, vectorised over channels: int32 window sums of 16 or 8 channels (SXTL,
// ADD), then the float32 requantisation; the last block overlaps the previous one; the loop nest is
// nn/avgpool_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/avgpool_i8_simd.h"

namespace ef::nn {

void avgpool_i8__neon(const PoolArgs& a) { avgpool_rows<ChannelBlocks<N16, N8>>(a); }

}  // namespace ef::nn
