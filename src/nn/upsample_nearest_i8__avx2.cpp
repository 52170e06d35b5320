// upsample_nearest_i8 at the AVX2 level: each input pixel's channels loaded once in blocks of 32
// bytes (then 16, 8, 4) and stored f times, repeated rows copied; the loop nest is
// nn/upsample_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/upsample_i8_simd.h"

namespace ef::nn {

void upsample_nearest_i8__avx2(const UpsampleArgs& a) { upsample_nearest_rows<ChannelBlocks<Y32, X16, X8, X4>>(a); }

}  // namespace ef::nn
