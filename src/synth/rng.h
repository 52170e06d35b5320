// Deterministic random numbers for the synthetic rooms: a PCG32 generator and integer hashes.
//
// Everything random in src/synth comes from here, never from <random> distributions (whose
// output is implementation-defined), so a seed gives the same rooms, frames and noise with any
// standard library, on x86 and ARM64. Only integer arithmetic and exactly rounded float
// operations (+ - * /) are used. Anything that could be contracted into a fused multiply-add
// (a * b + c) is defined out of line in rng.cpp, which is compiled with -ffp-contract=off: code
// including this header (tests) may be compiled with contraction, and an inline copy could then
// round differently on ARM64.
#pragma once

#include <cstdint>

namespace ef::synth {

// 32-bit integer hash with good avalanche (a "lowbias32" style mix); used for lattice noise and
// for per-object / per-frame seeds.
inline uint32_t hash32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}
inline uint32_t hash32(uint32_t a, uint32_t b) { return hash32(a ^ hash32(b + 0x9e3779b9U)); }
inline uint32_t hash32(uint32_t a, uint32_t b, uint32_t c) { return hash32(hash32(a, b), c); }

// A hash mapped to [0, 1) with 24 bits of resolution.
inline float hash_unit(uint32_t h) { return static_cast<float>(h >> 8) * (1.0f / 16777216.0f); }

// PCG32 (O'Neill 2014): 64-bit LCG state, 32-bit xorshift-rotate output.
class Pcg32 {
 public:
  explicit Pcg32(uint64_t seed, uint64_t stream = 0x5851f42d4c957f2dULL) {
    inc_ = (stream << 1u) | 1u;
    state_ = 0;
    next_u32();
    state_ += seed;
    next_u32();
  }

  uint32_t next_u32() {
    const uint64_t old = state_;
    state_ = old * 6364136223846793005ULL + inc_;
    const uint32_t xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
    const uint32_t rot = static_cast<uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
  }

  // Uniform in [0, 1), 24-bit resolution.
  float uniform() { return hash_unit(next_u32()); }
  // Uniform in [lo, hi) (rng.cpp).
  float uniform(float lo, float hi);
  // Uniform integer in [0, n), n > 0 (the tiny modulo bias is irrelevant here).
  uint32_t below(uint32_t n) { return next_u32() % n; }
  // True with probability p.
  bool chance(float p) { return uniform() < p; }

  // Approximately standard normal: the Irwin-Hall sum of four 16-bit uniforms, centred and scaled
  // to unit variance (range +-3.46). Arithmetic only, so bit-identical on every machine; the
  // clipped tails do not matter for sensor noise.
  float gaussian() {
    const uint32_t a = next_u32();
    const uint32_t b = next_u32();
    const uint32_t sum = (a & 0xffffu) + (a >> 16) + (b & 0xffffu) + (b >> 16);  // 0 .. 4 * 65535
    // mean 2 * 65535.5 (in 1/65536 units), variance 4/12 -> scale by sqrt(3).
    constexpr float kScale = 1.7320508f / 65536.0f;
    return (static_cast<float>(sum) - 131071.0f) * kScale;
  }

 private:
  uint64_t state_;
  uint64_t inc_;
};

}  // namespace ef::synth
