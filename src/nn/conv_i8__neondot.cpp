// conv_i8 for ARMv8.2 dot product: SDOT multiplies 4 signed input bytes by 4 signed weights and adds
// them into each int32 lane (16 multiply-adds per instruction). Signed x signed, so the input needs no
// offset; the pack folds z * sum(w) into the biases. Panels of 4 output channels;
// layout [tap][cin/4][4][4] int8.
#include <arm_neon.h>

#include <cstring>

#include "nn/conv_i8_neon.h"

namespace ef::nn {
namespace {

constexpr ConvPackLayout kLayout{4, 4, 1, 4, 0};

struct NeonDotTile {
  static constexpr int kMaxPanels = 4;
  static constexpr bool kSixPanelsAsThrees = false;
  // MR x NV accumulators + NV weights + one broadcast within 32 registers.
  template <int NV>
  static constexpr int pixels() { return NV == 1 ? 12 : NV == 2 ? 10 : NV == 3 ? 8 : 6; }

  template <int NV, int MR>
  static void run(const TileJob& j) {
    const ConvArgs& a = *j.a;
    const ConvPackHeader& h = conv_header(j.blob);
    const int32_t* bias = conv_bias(j.blob) + j.panel0 * 4;
    const int8_t* w[NV];
    for (int v = 0; v < NV; ++v) w[v] = reinterpret_cast<const int8_t*>(conv_panel(j.blob, j.panel0 + v));

    int32x4_t acc[MR][NV];
    for (int v = 0; v < NV; ++v) {
      const int32x4_t b = vld1q_s32(bias + 4 * v);
      for (int m = 0; m < MR; ++m) acc[m][v] = b;
    }
    const int full = h.cin / 4, tail = h.cin % 4;
    for (int ky = 0; ky < a.kernel_h; ++ky) {
      for (int kx = 0; kx < a.kernel_w; ++kx) {
        const int8_t* p[MR];
        tap_pointers<MR>(j, ky, kx, p);
        for (int s = 0; s < h.k_steps; ++s) {
          int8x16_t wv[NV];
          for (int v = 0; v < NV; ++v) wv[v] = vld1q_s8(w[v] + 16 * s);
          for (int m = 0; m < MR; ++m) {
            int32_t x;
            if (s < full) std::memcpy(&x, p[m] + 4 * s, 4);
            else x = int32_t(load_tail8(p[m] + 4 * s, tail));  // channels past cin have zero weights
            const int8x16_t b = vreinterpretq_s8_s32(vdupq_n_s32(x));
            for (int v = 0; v < NV; ++v) acc[m][v] = vdotq_s32(acc[m][v], wv[v], b);
          }
        }
        for (int v = 0; v < NV; ++v) w[v] += std::size_t(h.k_steps) * 16;
      }
    }

    store_tile_neon<NV, MR>(j, acc);
  }
};

std::size_t packed_bytes(const ConvShape& s) { return conv_packed_bytes(kLayout, s); }
void pack(const ConvShape& s, const ConvParams& p, void* dst) { conv_pack(kLayout, s, p, dst); }
void run(const ConvArgs& a) { conv_rows<NeonDotTile>(a); }

}  // namespace

const ConvKernel conv_i8__neondot = {packed_bytes, pack, run};

}  // namespace ef::nn
