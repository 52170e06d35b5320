// maxpool_i8 at the SSE4.1 level: NHWC, vectorised over channels, 16 per PMAXSB, 8-channel tails in
// the low half (MOVQ), the rest one at a time; the loop nest is nn/maxpool_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/maxpool_i8_simd.h"

namespace ef::nn {

void maxpool_i8__sse41(const PoolArgs& a) { maxpool_rows<PoolChannels<PoolX16, PoolX8>>(a); }

}  // namespace ef::nn
