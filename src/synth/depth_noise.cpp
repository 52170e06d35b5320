#include "synth/depth_noise.h"

#include <algorithm>
#include <cmath>

#include "synth/rng.h"

namespace ef::synth {

float depth_noise_sigma(const DepthNoiseOptions& o, float z) {
  const float dz = z - 0.4f;
  return o.sigma_base + o.sigma_quadratic * dz * dz;
}

float quantise_depth(const DepthNoiseOptions& o, float z) {
  if (!(z > 0)) return 0;
  const float disparity = std::nearbyint(o.disparity_scale / z);
  return disparity > 0 ? o.disparity_scale / disparity : 0.0f;
}

KinectNoise::KinectNoise(const DepthNoiseOptions& options, int width, int height) : o_(options) {
  edge_.allocate(width, height);
}

void KinectNoise::apply(uint64_t seed, ImageView<float> depth, ImageView<const float> incidence, ImageView<Rgb8> color) {
  const int w = depth.width, h = depth.height;
  // 1. Edges on the clean depth: a 4-neighbour with a jump of more than edge_jump + rel * z.
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float z = depth(x, y);
      const float thr = o_.edge_jump + o_.edge_jump_relative * z;
      bool edge = false;
      if (x > 0) edge = edge || std::fabs(depth(x - 1, y) - z) > thr;
      if (x + 1 < w) edge = edge || std::fabs(depth(x + 1, y) - z) > thr;
      if (y > 0) edge = edge || std::fabs(depth(x, y - 1) - z) > thr;
      if (y + 1 < h) edge = edge || std::fabs(depth(x, y + 1) - z) > thr;
      edge_(x, y) = edge ? 1 : 0;
    }
  }
  // 2. Per pixel: dropout decisions, axial noise, quantisation; colour noise.
  Pcg32 rng(seed, 0xda3e39cb94b95bdbULL);
  const float ramp_start = o_.max_range - 0.5f;
  const float graze_span = o_.grazing_cos_start - o_.grazing_cos_full;
  // Colour noise from two 4-bit nibbles: triangular on [-15, 15], standard deviation sqrt(42.5).
  const float color_scale = o_.color_sigma / 6.5192024f;
  for (int y = 0; y < h; ++y) {
    float* drow = depth.row(y);
    const float* irow = incidence.row(y);
    Rgb8* crow = color.row(y);
    for (int x = 0; x < w; ++x) {
      const float z = drow[x];
      const float g = rng.gaussian();
      const float u = rng.uniform();
      float p_drop = o_.random_dropout;
      if (edge_(x, y)) p_drop = std::max(p_drop, o_.edge_dropout);
      const float c = irow[x];
      if (c < o_.grazing_cos_start) p_drop = std::max(p_drop, std::min(1.0f, (o_.grazing_cos_start - c) / graze_span));
      if (z > ramp_start) p_drop = std::max(p_drop, std::min(1.0f, (z - ramp_start) / 0.5f));
      if (z < o_.min_range || z > o_.max_range || u < p_drop) {
        drow[x] = 0.0f;
      } else {
        drow[x] = quantise_depth(o_, z + depth_noise_sigma(o_, z) * g);
      }
      const uint32_t r = rng.next_u32();
      const auto noisy = [&](uint8_t value, int k) {
        const uint32_t b = (r >> (8 * k)) & 0xffu;
        const float n = static_cast<float>(static_cast<int>(b & 15u) + static_cast<int>(b >> 4) - 15) * color_scale;
        const float v = std::nearbyint(static_cast<float>(value) + n);
        return static_cast<uint8_t>(std::min(255.0f, std::max(0.0f, v)));
      };
      crow[x] = Rgb8{noisy(crow[x].r, 0), noisy(crow[x].g, 1), noisy(crow[x].b, 2)};
    }
  }
}

void apply_depth_bias(float bias, const Intrinsics& K, ImageView<float> depth) {
  const float half_w = 0.5f * static_cast<float>(K.width), half_h = 0.5f * static_cast<float>(K.height);
  const float inv_r2 = 1.0f / (half_w * half_w + half_h * half_h);
  for (int y = 0; y < depth.height; ++y) {
    float* row = depth.row(y);
    const float dy = static_cast<float>(y) - K.cy;
    for (int x = 0; x < depth.width; ++x) {
      const float dx = static_cast<float>(x) - K.cx;
      if (row[x] > 0.0f) row[x] *= 1.0f + bias * (dx * dx + dy * dy) * inv_r2;
    }
  }
}

}  // namespace ef::synth
