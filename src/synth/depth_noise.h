// Kinect-like sensor noise for the synthetic depth and colour images.
//
// Depth (structured-light Kinect v1): axial Gaussian noise sigma(z) = a + b (z - 0.4)^2 metres
// (Nguyen, Izadi, Lovell 2012), then quantisation to 1/8-pixel disparity steps with
// baseline * focal = 0.075 m * 580 px (Khoshelham & Elberink 2012: the step grows as z^2 / 348),
// then dropout: outside [min_range, max_range], at depth discontinuities, at grazing angles, and
// at random. Colour: small per-channel noise. All random numbers from a seeded Pcg32.
#pragma once

#include <cstdint>

#include "core/image.h"
#include "core/intrinsics.h"

namespace ef::synth {

struct DepthNoiseOptions {
  float sigma_base = 0.0012f;       // metres: axial noise at 0.4 m (Nguyen et al.)
  float sigma_quadratic = 0.0019f;  // metres per metre^2: growth with (z - 0.4)^2
  float disparity_scale = 348.0f;   // metres x disparity units: baseline (0.075 m) x focal (580 px) x 8 subpixels
  float min_range = 0.4f;           // metres: nearer pixels are invalid
  float max_range = 4.5f;           // metres: farther pixels are invalid; dropout ramps up over the last 0.5 m
  float edge_jump = 0.03f;          // metres: a neighbour this much (plus edge_jump_relative * z) nearer/farther is an edge
  float edge_jump_relative = 0.03f; // fraction of depth added to edge_jump
  float edge_dropout = 0.7f;        // probability that an edge pixel is invalid
  float grazing_cos_full = 0.08f;   // |cos| incidence below which a pixel is always invalid (~85 deg)
  float grazing_cos_start = 0.25f;  // |cos| below which dropout starts, ramping linearly to the above (~75 deg)
  float random_dropout = 0.003f;    // probability of a random invalid pixel
  float color_sigma = 1.2f;         // 8-bit levels: standard deviation of the colour noise per channel
};

// Standard deviation of the axial depth noise at depth z (metres) under `o`, metres.
float depth_noise_sigma(const DepthNoiseOptions& o, float z);
// Depth z (metres) quantised to the nearest disparity step.
float quantise_depth(const DepthNoiseOptions& o, float z);

class KinectNoise {
 public:
  // Allocates the scratch edge mask for width x height images.
  KinectNoise(const DepthNoiseOptions& options, int width, int height);

  const DepthNoiseOptions& options() const { return o_; }

  // Applies the noise in place to one frame; `seed` fixes every random draw (use one per frame).
  // `incidence`: |cos| between ray and surface normal per pixel (Renderer::incidence()).
  // Does not allocate.
  void apply(uint64_t seed, ImageView<float> depth, ImageView<const float> incidence, ImageView<Rgb8> color);

 private:
  DepthNoiseOptions o_;
  Image<uint8_t> edge_;
};

// A systematic depth error that grows towards the image's edges, as an uncalibrated depth camera's
// (Kinect depth bends flat walls by up to a few per cent at the corners): z *= 1 + bias * r^2, r the
// distance from the principal point over the half diagonal (1 at the corners). Frame-to-model
// tracking on such depth drifts slowly (a wall seen from two places bends differently), which is
// what loop closure is for: the synthetic source's depth_bias key. Invalid pixels (0) stay.
void apply_depth_bias(float bias, const Intrinsics& K, ImageView<float> depth);

}  // namespace ef::synth
