// clamp_i8 at the SSE4.1 level: the tensor as one flat run, 16 bytes per PMAXSB/PMINSB, then
// 8- and 4-byte blocks (MOVQ, MOVD), the last block overlapping the previous one; the loop is
// nn/clamp_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/clamp_i8_simd.h"

namespace ef::nn {

void clamp_i8__sse41(const ClampArgs& a) { clamp_flat<ChannelBlocks<X16, X8, X4>>(a); }

}  // namespace ef::nn
