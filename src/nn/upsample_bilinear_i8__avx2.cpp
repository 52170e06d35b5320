// upsample_bilinear_i8 at the AVX2 level: per output pixel, blocks of 32 channels (then 16, 8, 4):
// horizontal taps with VPMADDUBSW on interleaved bytes, vertical taps with VPMULLW, the exact 16-bit
// division (VPMULHUW and shifts) and VPACKUSWB; 9..15 channels as one 16-byte block that spills
// into the next pixel (upsample_bilinear_rows); factors above 8 run the reference. The loop nest is
// nn/upsample_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/upsample_i8_simd.h"

namespace ef::nn {

void upsample_bilinear_i8__avx2(const UpsampleArgs& a) { upsample_bilinear_rows<ChannelBlocks<Y32, X16, X8, X4>, X16>(a); }

}  // namespace ef::nn
