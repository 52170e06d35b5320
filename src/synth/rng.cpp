#include "synth/rng.h"

namespace ef::synth {

// Out of line and compiled with -ffp-contract=off: lo + (hi - lo) * u must not become a fused
// multiply-add on one ISA and two roundings on another.
float Pcg32::uniform(float lo, float hi) {
  const float u = uniform();
  return lo + (hi - lo) * u;
}

}  // namespace ef::synth
