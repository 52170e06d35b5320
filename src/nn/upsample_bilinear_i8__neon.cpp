// upsample_bilinear_i8 on NEON: per output pixel, blocks of 16 and 8 channels: horizontal taps with
// SMULL/SMLAL on bytes, vertical taps with MUL/ADD on int16 lanes, the exact 16-bit division (USHL,
// UMULL, SHRN) and XTN; 9..15 channels as one 16-byte block that spills into the next pixel
// (upsample_bilinear_rows); factors above 8 run the reference. The loop nest is nn/upsample_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/upsample_i8_simd.h"

namespace ef::nn {

void upsample_bilinear_i8__neon(const UpsampleArgs& a) { upsample_bilinear_rows<ChannelBlocks<N16, N8>, N16>(a); }

}  // namespace ef::nn
