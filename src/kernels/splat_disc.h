// Disc (surfel splat) rasterisation for slam/model_prediction: the per-pixel depth test of one
// surfel's disc over its screen bounding box, into a visibility-key buffer and a winner-id buffer.
//
// A pixel (x, y) with ray d = (ray_x[x], ray_y[y], 1) is covered by the disc (camera-frame centre
// p = (xc, yc, zc), unit normal n, radius r) when the ray meets the disc's plane on its front face
// (n . d < 0) at X = z d, z = (n . p) / (n . d), with |X - p|^2 = e2 <= r^2 and z >= near. Its key is
// z + (z * tie) * e2; the pixel takes the disc (key and id) when the key is below the stored one.
// The exact expression order (part of the contract, so that every variant gives the same bits):
//   denom = nx * dx + (ny * dy + nz)        z = np / min(denom, -1e-12)   (std::min(denom, -1e-12f))
//   ex = dx * z - xc   ey = dy * z - yc   ez = z - zc   e2 = (ex * ex + ey * ey) + ez * ez
//   key = z + (z * tie) * e2
//   wins = denom < 0 && e2 <= r2 && z >= near && key < key_buf[x]
// with every operation rounded separately (no fused multiply-add).
//
// Exactness: every variant (scalar, SSE4.1, AVX2, NEON) writes bit-identical buffers. SIMD variants
// work on 4 or 8 consecutive pixels of a row; a chunk that would cross the right image border is
// moved left to end at it (lanes outside [x0, x1] are masked), so no variant reads or writes outside
// [0, width) of a row. Images narrower than a variant's vector fall back to the scalar reference.
#pragma once

#include <cstdint>

namespace ef::kernels {

struct SplatDisc {
  float nx = 0, ny = 0, nz = 0;  // unit normal, camera frame
  float xc = 0, yc = 0, zc = 0;  // centre, camera frame, metres
  float np = 0;                  // nx * xc + ny * yc + nz * zc
  float r2 = 0;                  // radius^2, m^2
  float tie = 0;                 // visibility-key weight of e^2, per m^2
  float near = 0;                // smallest accepted z, metres
  int32_t id = -1;               // written to the winner buffer where the disc wins
  int x0 = 0, x1 = -1, y0 = 0, y1 = -1;  // pixel box, inclusive, inside [0, width) x [0, rows)
};

// Rasterises `d` over its box. key / winner: row-major with `width` elements per row (row y starts
// at key + y * width); ray_x: `width` floats; ray_y: one float per row. Dispatched to the best variant
// for this CPU (platform/cpu_features; EF_ISA caps it). No heap allocation.
void splat_disc(const SplatDisc& d, const float* ray_x, const float* ray_y, float* key, int32_t* winner, int width);

}  // namespace ef::kernels
