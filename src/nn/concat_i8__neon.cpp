// concat_i8 on NEON: per input and pixel, its channel run copied (same quantisation) or requantised
// (SXTL, SCVTF, FMUL, FMAX/FMIN, FCVTNS, SQXTN) in blocks of 16 and 8 channels, the last block
// overlapping the previous one; the loop nest is nn/concat_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/concat_i8_simd.h"

namespace ef::nn {

void concat_i8__neon(const ConcatArgs& a) { concat_channels<ChannelBlocks<N16, N8>>(a); }

}  // namespace ef::nn
