// upsample_nearest_i8 at the SSE4.1 level: each input pixel's channels loaded once in blocks of 16,
// 8 and 4 bytes and stored f times, repeated rows copied; the loop nest is nn/upsample_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/upsample_i8_simd.h"

namespace ef::nn {

void upsample_nearest_i8__sse41(const UpsampleArgs& a) { upsample_nearest_rows<ChannelBlocks<X16, X8, X4>>(a); }

}  // namespace ef::nn
