// upsample_nearest_i8 on NEON: each input pixel's channels loaded once in blocks of 16 and 8 bytes
// and stored f times, repeated rows copied; the loop nest is nn/upsample_i8_simd.h.
#include "nn/eltwise_kernels.h"
#include "nn/upsample_i8_simd.h"

namespace ef::nn {

void upsample_nearest_i8__neon(const UpsampleArgs& a) { upsample_nearest_rows<ChannelBlocks<N16, N8>>(a); }

}  // namespace ef::nn
