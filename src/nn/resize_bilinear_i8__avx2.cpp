// resize_bilinear_i8 at the AVX2 level: per output pixel, blocks of 32 channels, then the overlapping
// 16-, 8- and 4-channel tail blocks: horizontal taps with VPMADDWD on the flipped bytes widened to
// int16 pairs, the vertical tap with VPMULLD, the rounding shift and in-lane packs (no permute: the
// unpacks and packs cancel); pixels on an input pixel are copies. The loop nest is
// nn/resize_bilinear_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/resize_bilinear_i8_simd.h"

namespace ef::nn {

void resize_bilinear_i8__avx2(const ResizeArgs& a) { resize_bilinear_rows<ChannelBlocks<Y32, X16, X8, X4>>(a); }

}  // namespace ef::nn
