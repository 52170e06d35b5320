// depth_u16_to_metres for NEON (AArch64 baseline): 8 pixels per step.
#include <arm_neon.h>

#include "kernels/depth_u16_to_metres_variants.h"

namespace ef::kernels {

void depth_u16_to_metres__neon(const uint16_t* src, float* dst, std::size_t n, float metres_per_unit,
                               uint16_t max_valid_raw) {
  const float32x4_t scale = vdupq_n_f32(metres_per_unit);
  const uint16x8_t max_raw = vdupq_n_u16(max_valid_raw);
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const uint16x8_t raw = vld1q_u16(src + i);
    // 0xFFFF where raw != 0 and raw <= max.
    const uint16x8_t valid = vandq_u16(vtstq_u16(raw, raw), vcleq_u16(raw, max_raw));
    // Sign-extending the mask turns 0xFFFF into 0xFFFFFFFF.
    const uint32x4_t mask_lo = vreinterpretq_u32_s32(vmovl_s16(vreinterpret_s16_u16(vget_low_u16(valid))));
    const uint32x4_t mask_hi = vreinterpretq_u32_s32(vmovl_s16(vreinterpret_s16_u16(vget_high_u16(valid))));
    const float32x4_t m_lo = vmulq_f32(vcvtq_f32_u32(vmovl_u16(vget_low_u16(raw))), scale);
    const float32x4_t m_hi = vmulq_f32(vcvtq_f32_u32(vmovl_u16(vget_high_u16(raw))), scale);
    vst1q_f32(dst + i, vreinterpretq_f32_u32(vandq_u32(vreinterpretq_u32_f32(m_lo), mask_lo)));
    vst1q_f32(dst + i + 4, vreinterpretq_f32_u32(vandq_u32(vreinterpretq_u32_f32(m_hi), mask_hi)));
  }
  depth_u16_to_metres_ref(src + i, dst + i, n - i, metres_per_unit, max_valid_raw);
}

}  // namespace ef::kernels
