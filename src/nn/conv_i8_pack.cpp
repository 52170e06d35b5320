#include "nn/conv_i8_pack.h"

#include <cstring>
#include <new>

namespace ef::nn {

namespace {

std::size_t align64(std::size_t n) { return (n + 63) & ~std::size_t{63}; }

struct Sizes {
  int cin_pad, cout_pad, panels, taps, k_steps;
  std::size_t panel_bytes, bias_offset, mult_offset, pad_offset, weights_offset, total;
};

Sizes sizes_of(const ConvPackLayout& l, const ConvShape& s) {
  Sizes z{};
  z.cin_pad = (s.in_c + l.cin_multiple - 1) / l.cin_multiple * l.cin_multiple;
  z.panels = (s.out_c + l.lanes - 1) / l.lanes;
  z.cout_pad = z.panels * l.lanes;
  z.taps = s.kernel_h * s.kernel_w;
  z.k_steps = z.cin_pad / l.group;
  z.panel_bytes = align64(std::size_t(z.taps) * z.cin_pad * l.lanes * l.element_bytes);
  z.bias_offset = align64(sizeof(ConvPackHeader));
  z.mult_offset = z.bias_offset + align64(std::size_t(z.cout_pad) * 4);
  z.pad_offset = z.mult_offset + align64(std::size_t(z.cout_pad) * 4);
  z.weights_offset = z.pad_offset + align64(std::size_t(z.cin_pad));
  z.total = z.weights_offset + std::size_t(z.panels) * z.panel_bytes;
  return z;
}

}  // namespace

std::size_t conv_packed_bytes(const ConvPackLayout& layout, const ConvShape& shape) {
  return sizes_of(layout, shape).total;
}

void conv_pack(const ConvPackLayout& l, const ConvShape& s, const ConvParams& p, void* dst) {
  const Sizes z = sizes_of(l, s);
  char* base = static_cast<char*>(dst);
  std::memset(base, 0, z.total);
  ConvPackHeader* h = new (base) ConvPackHeader{};
  h->lanes = l.lanes; h->group = l.group; h->element_bytes = l.element_bytes;
  h->cin = s.in_c; h->cin_pad = z.cin_pad; h->cout = s.out_c; h->cout_pad = z.cout_pad;
  h->panels = z.panels; h->taps = z.taps; h->k_steps = z.k_steps; h->input_offset = l.input_offset;
  h->panel_bytes = uint32_t(z.panel_bytes);
  h->bias_offset = uint32_t(z.bias_offset); h->mult_offset = uint32_t(z.mult_offset);
  h->pad_offset = uint32_t(z.pad_offset); h->weights_offset = uint32_t(z.weights_offset);

  const std::size_t k_per_out = std::size_t(z.taps) * s.in_c;  // file layout [out][tap][cin]
  int32_t* bias = reinterpret_cast<int32_t*>(base + z.bias_offset);
  float* mult = reinterpret_cast<float*>(base + z.mult_offset);
  for (int o = 0; o < s.out_c; ++o) {
    const int8_t* w = p.weights + o * k_per_out;
    int64_t sum_w = 0;
    for (std::size_t k = 0; k < k_per_out; ++k) sum_w += w[k];
    // |bias| <= 2^30 and |(z + off) * sum_w| <= 255 * 127 * 32768 < 2^30: fits int32.
    bias[o] = static_cast<int32_t>(p.bias[o] - (int64_t(s.in_zero_point) + l.input_offset) * sum_w);
    mult[o] = p.requant[o].multiplier;
  }
  std::memset(base + z.pad_offset, static_cast<int8_t>(s.in_zero_point), std::size_t(z.cin_pad));

  for (int o = 0; o < s.out_c; ++o) {
    const int panel = o / l.lanes, lane = o % l.lanes;
    char* pw = base + z.weights_offset + std::size_t(panel) * z.panel_bytes;
    const int8_t* w = p.weights + o * k_per_out;
    for (int t = 0; t < z.taps; ++t) {
      for (int c = 0; c < s.in_c; ++c) {
        const int step = c / l.group, sub = c % l.group;
        const std::size_t e = ((std::size_t(t) * z.k_steps + step) * l.lanes + lane) * l.group + sub;
        const int8_t v = w[std::size_t(t) * s.in_c + c];
        if (l.element_bytes == 1) {
          pw[e] = v;
        } else {
          const int16_t v16 = v;
          std::memcpy(pw + 2 * e, &v16, 2);
        }
      }
    }
  }
}

}  // namespace ef::nn
