// avgpool_i8 at the SSE4.1 level: NHWC, vectorised over channels: int32 window sums of 16, 8 or 4
// channels (PMOVSXBD, PADDD), then the float32 requantisation; the last block overlaps the previous
// one; the loop nest is nn/avgpool_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/avgpool_i8_simd.h"

namespace ef::nn {

void avgpool_i8__sse41(const PoolArgs& a) { avgpool_rows<ChannelBlocks<X16, X8, X4>>(a); }

}  // namespace ef::nn
