// upsample_bilinear_i8 at the SSE4.1 level: per output pixel, blocks of 16, 8 and 4 channels:
// horizontal taps with PMADDUBSW on interleaved bytes, vertical taps with PMULLW, the exact 16-bit
// division (PMULHUW and shifts) and PACKUSWB; 9..15 channels as one 16-byte block that spills into
// the next pixel (upsample_bilinear_rows); factors above 8 run the reference. The loop nest is
// nn/upsample_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/upsample_i8_simd.h"

namespace ef::nn {

void upsample_bilinear_i8__sse41(const UpsampleArgs& a) { upsample_bilinear_rows<ChannelBlocks<X16, X8, X4>, X16>(a); }

}  // namespace ef::nn
