// clamp_i8 at the AVX-512 level (needs BW and VL only; named __avx512vnni, see kernels/variants.h):
// the tensor as one flat run, 64 bytes per VPMAXSB/VPMINSB zmm, then the overlapping 32- and 16-byte
// tail blocks (fewer than 16 bytes in all: one byte-masked block); the loop is nn/clamp_i8_simd.h.
//
// GCC 12 warns (-Wmaybe-uninitialized, and -Wuninitialized at -O1, an error in the debug build) about
// the unmasked forms of several AVX-512 intrinsics, which merge into _mm512_undefined_*(); the
// warning is false (every lane is written).
#ifndef __clang__  // a GCC warning group: clang has none of that name
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#pragma GCC diagnostic ignored "-Wuninitialized"

#include "nn/eltwise_kernels.h"
#include "nn/clamp_i8_simd.h"

namespace ef::nn {

void clamp_i8__avx512vnni(const ClampArgs& a) { clamp_flat<MaskedBlocks>(a); }

}  // namespace ef::nn
