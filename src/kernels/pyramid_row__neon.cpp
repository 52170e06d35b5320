// pyramid_row for NEON (AArch64 baseline): 4 coarse pixels per step in q registers, lane masks as
// all-ones uint32 lanes; LD2 de-interleaves a finer row's even and odd columns. Separate FMUL / FADD
// (this file turns contraction off, as every kernel); selects by BSL (FMIN's NaN and signed-zero rules
// are not C++'s conditional, so the minimum is a compare and a select as in the reference).
#include <arm_neon.h>

#include "kernels/f32_ops_neon.h"
#include "kernels/pyramid_row_simd.h"

namespace ef::kernels {

namespace {
struct Neon : F32Neon {
  static void load2(const float* p, F& even, F& odd) {
    const float32x4x2_t v = vld2q_f32(p);
    even = v.val[0];
    odd = v.val[1];
  }
};
}  // namespace

void pyramid_row__neon(const PyramidRow& r, int x_begin, int x_end, float* depth_out, float* intensity_out) {
  pyramid_row_simd<Neon>(r, x_begin, x_end, depth_out, intensity_out);
}

}  // namespace ef::kernels
