#include "synth/materials.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "synth/rng.h"

namespace ef::synth {

namespace {

using Vec3 = Eigen::Vector3f;

inline float fract(float x) { return x - std::floor(x); }
inline int32_t cell(float x) { return static_cast<int32_t>(std::floor(x)); }
inline float lattice(int32_t ix, int32_t iy, uint32_t seed) {
  // One hash per lattice point (texture evaluation dominates the render time).
  return hash_unit(hash32(static_cast<uint32_t>(ix) * 0x8da6b343U ^ static_cast<uint32_t>(iy) * 0xd8163841U ^ seed));
}
inline float smooth(float t) { return t * t * (3.0f - 2.0f * t); }
inline Vec3 mix(const Vec3& a, const Vec3& b, float t) { return a + (b - a) * t; }
inline float clamp01(float x) { return std::min(std::max(x, 0.0f), 1.0f); }

// Per-cell random value in [0, 1) (tiles, planks, books).
inline float cell_random(int32_t i, int32_t j, uint32_t seed) { return lattice(i, j, seed ^ 0xa5a5a5a5U); }

// A colour with each channel scaled by its own random factor in [1 - amount, 1 + amount].
Vec3 jitter(const Vec3& c, uint32_t h, float amount) {
  const float r = hash_unit(hash32(h, 1)), g = hash_unit(hash32(h, 2)), b = hash_unit(hash32(h, 3));
  return Vec3(c.x() * (1 + amount * (2 * r - 1)), c.y() * (1 + amount * (2 * g - 1)), c.z() * (1 + amount * (2 * b - 1)));
}

// Wood grain: rings along u, warped by noise; `t` in [0, 1] says how dark.
float grain(float u, float v, float period, uint32_t seed) {
  const float warp = 2.5f * fractal_noise(u * 0.4f / period, v * 3.0f / period, seed);
  const float ring = fract(v / period * 1.7f + warp);
  const float fine = value_noise(u * 40.0f, v * 2.0f / period, seed + 7);
  return clamp01(0.65f * std::fabs(2.0f * ring - 1.0f) + 0.35f * fine);
}

Vec3 painting_colour(float u, float v, uint32_t seed) {
  // A few coloured regions (thresholds of fractal noise) over a gradient: an "abstract" picture
  // with strong gradients for photometric tracking.
  static const Vec3 kPalette[8] = {{0.85f, 0.2f, 0.15f}, {0.95f, 0.75f, 0.2f}, {0.15f, 0.35f, 0.8f},
                                   {0.2f, 0.6f, 0.3f},   {0.9f, 0.9f, 0.85f}, {0.5f, 0.2f, 0.6f},
                                   {0.1f, 0.1f, 0.15f},  {0.95f, 0.5f, 0.6f}};
  const float n = fractal_noise(u * 6.0f, v * 6.0f, seed);
  const int idx = std::min(7, static_cast<int>(n * 8.0f));
  const Vec3 a = kPalette[(idx + seed) % 8];
  const Vec3 b = kPalette[(idx + seed + 3) % 8];
  return mix(a, b, smooth(fract(n * 8.0f)));
}

}  // namespace

float value_noise(float x, float y, uint32_t seed) {
  const int32_t ix = cell(x), iy = cell(y);
  const float fx = smooth(x - static_cast<float>(ix)), fy = smooth(y - static_cast<float>(iy));
  const float a = lattice(ix, iy, seed), b = lattice(ix + 1, iy, seed);
  const float c = lattice(ix, iy + 1, seed), d = lattice(ix + 1, iy + 1, seed);
  const float top = a + (b - a) * fx, bottom = c + (d - c) * fx;
  return top + (bottom - top) * fy;
}

float fractal_noise(float x, float y, uint32_t seed) {
  return (0.5714286f * value_noise(x, y, seed) + 0.2857143f * value_noise(2.03f * x, 2.03f * y, seed + 1) +
          0.1428571f * value_noise(4.07f * x, 4.07f * y, seed + 2));
}

Vec3 albedo(const Material& m, float u, float v, float hu, float hv) {
  const float s = m.scale;
  switch (m.texture) {
    case TextureKind::kPlain:
      return m.base * (0.88f + 0.24f * fractal_noise(u / s, v / s, m.seed));
    case TextureKind::kPlaster: {
      const float low = fractal_noise(u * 1.3f, v * 1.3f, m.seed);    // stains, ~0.8 m
      const float mid = value_noise(u / s, v / s, m.seed + 11);       // blotches of `scale`
      const float fine = value_noise(u * 90.0f, v * 90.0f, m.seed + 5);  // grain, ~1 cm
      return m.base * (0.72f + 0.22f * low + 0.12f * mid + 0.08f * fine);
    }
    case TextureKind::kWallpaper: {
      const float stripe = fract(u / s);
      const bool band = stripe < 0.5f;
      // A small diamond motif every half stripe, to give gradients along v too.
      const float mu = fract(u / (0.5f * s)) - 0.5f, mv = fract(v / (0.5f * s)) - 0.5f;
      const bool motif = std::fabs(mu) + std::fabs(mv) < 0.18f;
      Vec3 c = band ? m.base : mix(m.base, m.accent, 0.5f);
      if (motif) c = m.accent;
      return c * (0.85f + 0.15f * fractal_noise(u * 2.0f, v * 2.0f, m.seed));
    }
    case TextureKind::kWood: {
      const float g = grain(u, v, s, m.seed);
      return mix(m.base, m.accent, 0.75f * g);
    }
    case TextureKind::kPlanks: {
      // Planks of width s along v, 1.2 m long along u, staggered per row.
      const float row_f = v / s;
      const int32_t row = cell(row_f);
      const float offset = cell_random(row, 0, m.seed) * 1.2f;
      const float along = (u + offset) / 1.2f;
      const int32_t plank = cell(along);
      const float seam_v = fract(row_f), seam_u = fract(along);
      if (seam_v < 0.03f || seam_u < 0.006f) return m.accent * 0.45f;
      const Vec3 tint = jitter(m.base, hash32(static_cast<uint32_t>(row), static_cast<uint32_t>(plank), m.seed), 0.15f);
      return mix(tint, m.accent, 0.6f * grain(v, u, 0.35f * s, m.seed + static_cast<uint32_t>(plank)));
    }
    case TextureKind::kFabric: {
      const float n = fractal_noise(u / s, v / s, m.seed);
      const int32_t wu = cell(u * 250.0f), wv = cell(v * 250.0f);  // 4 mm weave
      const float weave = ((wu + wv) & 1) ? 0.94f : 1.06f;
      return mix(m.base, m.accent, 0.5f * n) * weave;
    }
    case TextureKind::kTiles: {
      const float fu = fract(u / s), fv = fract(v / s);
      if (fu < 0.04f || fv < 0.04f) return m.accent;
      const float r = cell_random(cell(u / s), cell(v / s), m.seed);
      return m.base * (0.85f + 0.25f * r) * (0.95f + 0.1f * value_noise(u * 30.0f, v * 30.0f, m.seed + 3));
    }
    case TextureKind::kStripes: {
      const float t = fract(v / s);
      const float w = smooth(clamp01((std::fabs(t - 0.5f) - 0.2f) * 10.0f));
      return mix(m.base, m.accent, w) * (0.9f + 0.2f * value_noise(u * 20.0f, v * 20.0f, m.seed));
    }
    case TextureKind::kBookSpines: {
      // Books of ~s wide along u with jittered boundaries; each its own colour, a title band.
      static const Vec3 kCovers[8] = {{0.6f, 0.1f, 0.1f}, {0.1f, 0.2f, 0.5f},  {0.1f, 0.4f, 0.2f},
                                      {0.8f, 0.7f, 0.5f}, {0.15f, 0.15f, 0.15f}, {0.7f, 0.4f, 0.1f},
                                      {0.5f, 0.5f, 0.6f}, {0.85f, 0.85f, 0.8f}};
      const float x = u / s + 0.35f * value_noise(u / s, 0.5f, m.seed);
      const int32_t book = cell(x);
      const uint32_t h = hash32(static_cast<uint32_t>(book), m.seed);
      const float edge = fract(x);
      if (edge < 0.06f) return Vec3(0.05f, 0.05f, 0.05f);
      const Vec3 cover = jitter(kCovers[h % 8], h, 0.2f);
      const float rel = hv > 0 ? (v + hv) / (2 * hv) : 0.5f;  // 0 at the bottom, 1 at the top
      const float band = hash_unit(hash32(h, 9)) * 0.3f + 0.55f;
      if (std::fabs(rel - band) < 0.05f) return Vec3(0.85f, 0.7f, 0.25f);  // gilt title band
      return cover;
    }
    case TextureKind::kSky: {
      // Frame and cross bars (accent), then a sky with clouds brightening towards the horizon.
      const float frame = 0.06f;
      if ((hu > 0 && std::fabs(u) > hu - frame) || (hv > 0 && std::fabs(v) > hv - frame) || std::fabs(u) < 0.025f ||
          std::fabs(v) < 0.025f)
        return m.accent;
      const float rel = hv > 0 ? (v + hv) / (2 * hv) : 0.5f;
      const Vec3 sky = mix(Vec3(0.85f, 0.9f, 0.95f), m.base, rel);
      const float cloud = clamp01((fractal_noise(u * 1.5f, v * 3.0f, m.seed) - 0.45f) * 3.0f);
      Vec3 c = mix(sky, Vec3(1.0f, 1.0f, 1.0f), cloud);
      if (rel < 0.25f) c = mix(Vec3(0.25f, 0.45f, 0.2f), Vec3(0.4f, 0.55f, 0.3f), fractal_noise(u * 8, v * 8, m.seed + 4));
      return c;
    }
    case TextureKind::kPainting: {
      const float frame = 0.05f;
      if ((hu > 0 && std::fabs(u) > hu - frame) || (hv > 0 && std::fabs(v) > hv - frame))
        return mix(m.accent, m.accent * 0.5f, grain(u, v, 0.02f, m.seed));
      return painting_colour(u, v, m.seed);
    }
    case TextureKind::kScreen: {
      const float bezel = 0.025f;
      if ((hu > 0 && std::fabs(u) > hu - bezel) || (hv > 0 && std::fabs(v) > hv - bezel)) return m.accent;
      // A dim picture: blocky, colourful, so the screen has gradients.
      const float n = fractal_noise(u * 4.0f, v * 4.0f, m.seed);
      return mix(m.base, painting_colour(u * 0.7f, v * 0.7f, m.seed + 1), 0.6f * n);
    }
  }
  return m.base;
}

}  // namespace ef::synth
