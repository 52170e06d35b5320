// upsample_nearest_i8 at the AVX-512 level (needs BW and VL only; named __avx512vnni, see
// kernels/variants.h): each input pixel's channels loaded once in 64-byte blocks, then the
// overlapping 32- and 16-byte tail blocks, or one byte-masked block when C < 16, and stored f times;
// repeated rows copied; the loop nest is nn/upsample_i8_simd.h.
//
// GCC 12 warns (-Wmaybe-uninitialized, and -Wuninitialized at -O1, an error in the debug build) about
// the unmasked forms of several AVX-512 intrinsics, which merge into _mm512_undefined_*(); the
// warning is false (every lane is written).
#ifndef __clang__  // a GCC warning group: clang has none of that name
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#pragma GCC diagnostic ignored "-Wuninitialized"

#include "nn/eltwise_kernels.h"
#include "nn/upsample_i8_simd.h"

namespace ef::nn {

void upsample_nearest_i8__avx512vnni(const UpsampleArgs& a) { upsample_nearest_rows<MaskedBlocks>(a); }

}  // namespace ef::nn
