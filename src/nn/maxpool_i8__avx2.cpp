// maxpool_i8 at the AVX2 level: NHWC, vectorised over channels, 32 per VPMAXSB ymm, then 16- and
// 8-channel blocks and single channels for narrow layers; the loop nest is nn/maxpool_i8_simd.h.
#include <immintrin.h>

#include "nn/eltwise_kernels.h"
#include "nn/maxpool_i8_simd.h"

namespace ef::nn {
namespace {

struct Y32 {
  using R = __m256i;
  static constexpr int kLanes = 32;
  static R lowest() { return _mm256_set1_epi8(-128); }
  static R load(const int8_t* p) { return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p)); }
  static R max(R a, R b) { return _mm256_max_epi8(a, b); }
  static void store(int8_t* p, R v) { _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), v); }
};

}  // namespace

void maxpool_i8__avx2(const PoolArgs& a) { maxpool_rows<PoolChannels<Y32, PoolX16, PoolX8>>(a); }

}  // namespace ef::nn
