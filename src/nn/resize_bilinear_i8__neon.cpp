// resize_bilinear_i8 on NEON: per output pixel, blocks of 16 and 8 channels (the last block
// overlapping the previous one): horizontal taps with UMULL / UMLAL on the flipped bytes widened to
// uint16, the vertical tap with MUL on int32 lanes, the rounding shift and XTN; pixels on an input
// pixel are copies. The loop nest is nn/resize_bilinear_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/resize_bilinear_i8_simd.h"

namespace ef::nn {

void resize_bilinear_i8__neon(const ResizeArgs& a) { resize_bilinear_rows<ChannelBlocks<N16, N8>>(a); }

}  // namespace ef::nn
