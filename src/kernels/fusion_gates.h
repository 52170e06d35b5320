// The static gates of fusion's data association (slam/surfel_fusion.h, step 1) for one row of
// working pixels, at index-map scale 1: for each pixel, which of the 3x3 index pixels around its own
// hold a surfel, and which of those pass the depth gate, the free-space test and the normal gate as
// the index map's copy of the surfel (slam/index_map.h) sees them. Association then reads one code
// per pixel instead of testing each candidate with branches that no predictor learns (about half
// the pixels find nothing in their own index pixel and look at the eight around it).
//
// What stays with the caller: the surfels this frame has already updated or merged (their pool
// values replace the index map's copy), the order of the visits and the choice among the passing
// candidates.
//
// Cell k of a pixel (x, y), k = 0..8, is the index pixel (x + k % 3 - 1, y + k / 3 - 1): row-major,
// k = 4 the pixel's own. Per pixel, with z its depth in the index map's camera, g its depth gate
// (metres), n its world normal, and per cell the map's id, depth d and surface normal s:
//   occupied    0 <= id < pool_size
//   invalid     id >= pool_size (a stale map; the caller takes its slow path)
//   dz = d - z; violated = dz < neg_free_space_factor * g
//   depth_ok    !violated && !(|dz| > g)
//   normal_ok   !(cos < cos_normal_gate), cos = (s.x n.x + s.y n.y) + s.z n.z
//   identity    ceil(xi - 0.5) == x and ceil(yi - 0.5) == y: the pixel projects into its own index
//               pixel (the map was rendered at the frame's pose), so that the 3x3 cells are its window
// Code bits: occupied at bit k, depth_ok at 9 + k, normal_ok at 18 + k (both only where occupied),
// bit 27 the own cell occupied and violated, bit 28 some cell invalid, bit 29 identity.
// Every operation is one IEEE float operation in the order written (kernel files build with
// contraction off), so every variant writes the same codes as the scalar reference.
#pragma once

#include <cstdint>

namespace ef::kernels {

inline constexpr int kGateDepthShift = 9;
inline constexpr int kGateNormalShift = 18;
inline constexpr uint32_t kGateCells = 0x1FFu;
inline constexpr uint32_t kGateOwnCell = 1u << 4;
inline constexpr uint32_t kGateOwnViolated = 1u << 27;
inline constexpr uint32_t kGateInvalid = 1u << 28;
inline constexpr uint32_t kGateIdentity = 1u << 29;

struct FusionGateParams {
  // Index map rows y - 1, y, y + 1 (each pointer at index pixel 0 of its row): surfel ids (-1 =
  // none), their depths (metres, index camera) and surfaces (4 floats per index pixel: world normal
  // x, y, z and confidence).
  const int32_t* id[3] = {nullptr, nullptr, nullptr};
  const float* depth[3] = {nullptr, nullptr, nullptr};
  const float* surface[3] = {nullptr, nullptr, nullptr};
  int32_t pool_size = 0;
  float neg_free_space_factor = -2.0f;  // -FusionOptions::free_space_gate_factor
  float cos_normal_gate = 0.866f;       // cos(association_normal_deg)
  int y = 0;                            // the working row
};

// The row's pixels, one float each, indexed by x: projection into the index grid (xi, yi), depth in
// the index camera (z, metres), depth gate (metres), world normal.
struct FusionGateRow {
  const float* xi = nullptr;
  const float* yi = nullptr;
  const float* z = nullptr;
  const float* gate = nullptr;
  const float* nwx = nullptr;
  const float* nwy = nullptr;
  const float* nwz = nullptr;
};

// Writes code[x] for x in [x_begin, x_end); needs 1 <= x_begin and x_end <= width - 1 of the index
// rows (every cell read lies inside them). Dispatched to the best variant for this CPU
// (platform/cpu_features; EF_ISA caps it). No heap allocation.
void fusion_gates(const FusionGateParams& p, const FusionGateRow& row, int x_begin, int x_end, uint32_t* code);

}  // namespace ef::kernels
