// avgpool_i8 at the AVX-512 level (needs BW and VL only; named __avx512vnni, see kernels/variants.h):
// NHWC, vectorised over channels: int32 window sums of 64 channels in four zmm, then the overlapping
// 32- and 16-channel tail blocks, or one byte-masked block when C < 16 (MaskedBlocks,
// nn/int8_simd.h), then the float32 requantisation; the loop nest is nn/avgpool_i8_simd.h.
//
// GCC 12 warns (-Wmaybe-uninitialized, and -Wuninitialized at -O1, an error in the debug build) about
// the unmasked forms of several AVX-512 intrinsics, which merge into _mm512_undefined_*(); the
// warning is false (every lane is written).
#ifndef __clang__  // a GCC warning group: clang has none of that name
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#pragma GCC diagnostic ignored "-Wuninitialized"

#include "nn/eltwise_kernels.h"
#include "nn/avgpool_i8_simd.h"

namespace ef::nn {

void avgpool_i8__avx512vnni(const PoolArgs& a) { avgpool_rows<MaskedBlocks>(a); }

}  // namespace ef::nn
