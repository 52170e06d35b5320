// The test twin of conv_i8__avxvnni (nn/conv_i8_twins.h): the same source, nn/conv_i8_vnni256.h,
// with the EVEX encoding of 256-bit VPDPBUSD (AVX-512 VNNI + VL), the same instruction with the
// same result, so CPUs with AVX-512 VNNI but without AVX-VNNI test the AVX-VNNI code. Not in any
// dispatch table: only the tests reference it (a static library leaves it out of the programs).
// GCC 12's AVX-512 headers pass undefined vectors as unused merge sources, which
// -Werror=uninitialized reports as maybe-uninitialized (GCC PR 105593).
#ifndef __clang__  // a GCC warning group: clang has none of that name
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <immintrin.h>

#include "nn/conv_i8_twins.h"
#include "nn/conv_i8_vnni256.h"

namespace ef::nn {
namespace {

struct EvexDpbusd {
  static __m256i dpbusd(__m256i acc, __m256i u, __m256i w) { return _mm256_dpbusd_epi32(acc, u, w); }
};

void run(const ConvArgs& a) { conv_rows<Vnni256Tile<EvexDpbusd>>(a); }

}  // namespace

const ConvKernel conv_i8_vnni256_twin__avx512vnni = {vnni256_packed_bytes, vnni256_pack, run};

}  // namespace ef::nn
