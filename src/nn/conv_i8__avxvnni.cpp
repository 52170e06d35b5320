// conv_i8 for AVX-VNNI: the 256-bit VPDPBUSD tile of nn/conv_i8_vnni256.h with the VEX encoding
// (Alder Lake and later cores without AVX-512): 32 multiply-adds per instruction, panels of 8 output
// channels, input bytes flipped to unsigned and the flip folded into the biases. Its code runs in
// the tests through the EVEX twin conv_i8_vnni256_twin__avx512vnni (nn/conv_i8_twins.h) on CPUs
// that lack AVX-VNNI but have AVX-512 VNNI.
#include <immintrin.h>

#include "nn/conv_i8_vnni256.h"

namespace ef::nn {
namespace {

struct VexDpbusd {
  static __m256i dpbusd(__m256i acc, __m256i u, __m256i w) { return _mm256_dpbusd_avx_epi32(acc, u, w); }
};

void run(const ConvArgs& a) { conv_rows<Vnni256Tile<VexDpbusd>>(a); }

}  // namespace

const ConvKernel conv_i8__avxvnni = {vnni256_packed_bytes, vnni256_pack, run};

}  // namespace ef::nn
