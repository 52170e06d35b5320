// Which surfels a camera actually sees, for label fusion and label rendering.
//
// The index map (slam/index_map.h) is 2x (up to 4x) finer than the image and holds surfel centres
// as points, so a pixel's 4 (up to 16) cells also catch centres of surfels hidden behind the visible
// surface (their cells are simply not covered by a nearer centre). Such a surfel must not take the CNN's label of the
// occluding object (the paper's update is over the *visible* surfels), nor show in a rendering. The
// test: a surfel is visible at a pixel when its camera depth agrees with the depth measured there,
//   |z_surfel - z_measured| <= abs_m + rel * z_measured,
// a band a few times the sensor's noise (Kinect: about 1.5 mm at 0.5 m to 4 cm at 4 m, growing with
// z^2) and much smaller than the gap between a surface and what it hides.
#pragma once

#include <cmath>

namespace ef::semantic {

struct DepthGate {
  float abs_m = 0.03f;  // metres; default 3 cm
  float rel = 0.03f;    // fraction of the measured depth; default 3% (12 cm at 4 m)
  // z_measured > 0 (a pixel without depth gives no evidence: callers decide what to do there).
  bool accepts(float z_surfel, float z_measured) const {
    return std::fabs(z_surfel - z_measured) <= abs_m + rel * z_measured;
  }
};

}  // namespace ef::semantic
