// label_update for AArch64 Advanced SIMD: one surfel per q register, UQADD then UMINV for the
// horizontal minimum (the spare bytes are 255, so the min over 16 bytes is the class min).
#include <arm_neon.h>

#include "kernels/label_update_variants.h"

namespace ef::kernels {

// Prefetch distance (pairs): the surfels are random rows of a store far larger than the caches.
static constexpr std::size_t kPrefetch = 16;

void label_update__neon(uint8_t* store, const uint8_t* obs, const LabelUpdatePair* pairs, std::size_t n) {
  static const uint8_t kKeep[16] = {255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 0, 0};
  const uint8x16_t keep = vld1q_u8(kKeep);
  for (std::size_t i = 0; i < n; ++i) {
    if (i + kPrefetch + 0 < n) __builtin_prefetch(store + std::size_t(pairs[i + kPrefetch + 0].surfel) * kLabelUpdateBytes, 1);
    uint8_t* s = store + std::size_t(pairs[i].surfel) * kLabelUpdateBytes;
    const uint8_t* o = obs + std::size_t(pairs[i].observation) * kLabelUpdateBytes;
    const uint8x16_t t = vqaddq_u8(vld1q_u8(s), vld1q_u8(o));
    const uint8x16_t m = vdupq_n_u8(vminvq_u8(t));
    vst1q_u8(s, vandq_u8(vsubq_u8(t, m), keep));
  }
}

}  // namespace ef::kernels
