// resize_bilinear_i8 at the SSE4.1 level: per output pixel, blocks of 16, 8 and 4 channels (the last
// block overlapping the previous one): horizontal taps with PMADDWD on the flipped bytes widened to
// int16 pairs, the vertical tap with PMULLD, the rounding shift and PACKUSDW / PACKUSWB; pixels on an
// input pixel are copies. The loop nest is nn/resize_bilinear_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/resize_bilinear_i8_simd.h"

namespace ef::nn {

void resize_bilinear_i8__sse41(const ResizeArgs& a) { resize_bilinear_rows<ChannelBlocks<X16, X8, X4>>(a); }

}  // namespace ef::nn
