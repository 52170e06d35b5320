// Procedural textures: the albedo of a material at a point of a surface.
#pragma once

#include <Eigen/Core>

#include "synth/scene.h"

namespace ef::synth {

// Smooth value noise in [0, 1] on a unit lattice (x, y in lattice cells), from integer hashes.
float value_noise(float x, float y, uint32_t seed);
// Three octaves of value_noise, in [0, 1].
float fractal_noise(float x, float y, uint32_t seed);

// Linear albedo (each channel in [0, 1]) of `m` at surface coordinates (u, v), metres, measured
// from the face's centre (u to the right along the face, v up for vertical faces). (hu, hv): half
// size of the face along u and v in metres, used by framed patterns (windows, paintings, screens);
// 0 for unbounded surfaces (room faces).
Eigen::Vector3f albedo(const Material& m, float u, float v, float hu, float hv);

}  // namespace ef::synth
