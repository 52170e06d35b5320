// conv_i8 for AArch64 without dot product: SMLAL multiplies 4 int16 weights (one input channel, 4
// output channels) by one int16 lane of the widened input and accumulates into int32, so each
// 8-channel chunk of a pixel is widened once (SXTL) and used lane by lane. Panels of 4 output
// channels; layout [tap][cin][4] int16 (cin padded to 8); the pack folds z * sum(w) into the biases.
#include <arm_neon.h>

#include <cstring>

#include "nn/conv_i8_neon.h"

namespace ef::nn {
namespace {

constexpr ConvPackLayout kLayout{4, 1, 2, 8, 0};

template <int L, int NV, int MR>
inline void mla_lane(int32x4_t (&acc)[MR][NV], const int16_t* const (&w)[NV], int c, const int16x8_t (&x)[MR]) {
  for (int v = 0; v < NV; ++v) {
    const int16x4_t wv = vld1_s16(w[v] + (8 * c + L) * 4);
    for (int m = 0; m < MR; ++m) acc[m][v] = vmlal_laneq_s16(acc[m][v], wv, x[m], L);
  }
}

struct NeonTile {
  static constexpr int kMaxPanels = 4;
  static constexpr bool kSixPanelsAsThrees = false;
  // MR x NV accumulators + MR widened pixels + one weight register within 32.
  template <int NV>
  static constexpr int pixels() { return NV == 1 ? 12 : NV == 2 ? 8 : NV == 3 ? 6 : 5; }

  template <int NV, int MR>
  static void run(const TileJob& j) {
    const ConvArgs& a = *j.a;
    const ConvPackHeader& h = conv_header(j.blob);
    const int32_t* bias = conv_bias(j.blob) + j.panel0 * 4;
    const int16_t* w[NV];
    for (int v = 0; v < NV; ++v) w[v] = reinterpret_cast<const int16_t*>(conv_panel(j.blob, j.panel0 + v));

    int32x4_t acc[MR][NV];
    for (int v = 0; v < NV; ++v) {
      const int32x4_t b = vld1q_s32(bias + 4 * v);
      for (int m = 0; m < MR; ++m) acc[m][v] = b;
    }
    const int chunks = h.cin_pad / 8, tail = h.cin % 8;
    const int full = tail ? chunks - 1 : chunks;
    for (int ky = 0; ky < a.kernel_h; ++ky) {
      for (int kx = 0; kx < a.kernel_w; ++kx) {
        const int8_t* p[MR];
        tap_pointers<MR>(j, ky, kx, p);
        for (int c = 0; c < chunks; ++c) {
          int16x8_t x[MR];
          for (int m = 0; m < MR; ++m) {
            int8x8_t bytes;
            if (c < full) {
              bytes = vld1_s8(p[m] + 8 * c);
            } else {
              const uint64_t t = load_tail8(p[m] + 8 * c, tail);  // channels past cin have zero weights
              bytes = vreinterpret_s8_u64(vcreate_u64(t));
            }
            x[m] = vmovl_s8(bytes);
          }
          const int16_t* const(&wr)[NV] = w;
          mla_lane<0>(acc, wr, c, x); mla_lane<1>(acc, wr, c, x);
          mla_lane<2>(acc, wr, c, x); mla_lane<3>(acc, wr, c, x);
          mla_lane<4>(acc, wr, c, x); mla_lane<5>(acc, wr, c, x);
          mla_lane<6>(acc, wr, c, x); mla_lane<7>(acc, wr, c, x);
        }
        for (int v = 0; v < NV; ++v) w[v] += std::size_t(h.cin_pad) * 4;
      }
    }

    store_tile_neon<NV, MR>(j, acc);
  }
};

std::size_t packed_bytes(const ConvShape& s) { return conv_packed_bytes(kLayout, s); }
void pack(const ConvShape& s, const ConvParams& p, void* dst) { conv_pack(kLayout, s, p, dst); }
void run(const ConvArgs& a) { conv_rows<NeonTile>(a); }

}  // namespace

const ConvKernel conv_i8__neon = {packed_bytes, pack, run};

}  // namespace ef::nn
