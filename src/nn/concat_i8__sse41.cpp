// concat_i8 at the SSE4.1 level: per input and pixel, its channel run copied (same quantisation) or
// requantised (PMOVSXBD, CVTDQ2PS, MULPS, MAXPS/MINPS, CVTPS2DQ, packs) in blocks of 16, 8 and 4
// channels, the last block overlapping the previous one; the loop nest is nn/concat_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/concat_i8_simd.h"

namespace ef::nn {

void concat_i8__sse41(const ConcatArgs& a) { concat_channels<ChannelBlocks<X16, X8, X4>>(a); }

}  // namespace ef::nn
