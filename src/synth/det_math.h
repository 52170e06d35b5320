// Trigonometry that gives the same bits on every machine, for the synthetic rooms.
//
// libm's sin, cos and atan2 are not specified to the last bit: glibc on x86-64 (with its FMA
// variants) and on ARM64 can round differently, and one flipped bit in a room's layout or a pose
// changes every frame after it. These are evaluated here instead with a fixed sequence of exactly
// rounded double operations (+ - * /, no fused multiply-add: src/synth is compiled with
// -ffp-contract=off and the definitions live in det_math.cpp, never inline in a header), so a
// seed gives the same rooms and trajectories on x86-64 and ARM64. Accuracy: a few units in the
// last place of a double over |x| < 1e6, far below anything the generator can see.
#pragma once

namespace ef::synth {

// sin(x) and cos(x), x in radians with |x| < 1e6 (larger: NaN).
void det_sincos(double x, double& s, double& c);
double det_sin(double x);
double det_cos(double x);
// atan2(y, x) in [-pi, pi], radians; atan2(0, 0) = 0.
double det_atan2(double y, double x);

// Single-precision sine and cosine: the double results rounded once to float.
void det_sincosf(float x, float& s, float& c);

}  // namespace ef::synth
