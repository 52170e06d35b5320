// The colour camera of a consumer RGB-D sensor (Kinect v1 class), applied on top of the renderer's
// ideal images: motion blur over the shutter time, vignetting, auto-exposure with highlight
// clipping, grey-world auto white balance, and signal-dependent (shot) noise.
//
// Why: the renderer shades surfaces as Lambertian, so without this one surface looks the same from
// every view, and a CNN's mistakes on it repeat in every view. On a real recording the same surface
// is brighter or darker (exposure follows what else is in view), tinted (white balance), blurred
// when the camera turns, and darker near the image corners: view-to-view changes that a map fusing
// many views can use to correct single-frame mistakes. (Measured on the synthetic rooms: with a CNN
// trained on this camera its mistakes become only a little less repeatable; docs/results.md, issue 6,
// stop 22.)
//
// Determinism: only + - * / and sqrt (exactly rounded) in this module's float code, compiled with
// -ffp-contract=off, and the seeded Pcg32; so a URI gives the same bytes on x86-64 and ARM64.
#pragma once

#include <cstdint>
#include <vector>

#include "core/image.h"
#include "core/se3.h"
#include "synth/renderer.h"

namespace ef::synth {

struct CameraModelOptions {
  float shutter_s = 0.020f;          // seconds: exposure time; blur integrates the camera's motion over it, centred on the frame's time (at most two frame intervals count)
  int blur_samples = 5;              // renders averaged over the shutter (1 = no blur); an even count is raised to the next odd one, so the middle render is the frame's own pose
  float vignetting = 0.35f;          // fraction of light lost at the image corners; the loss grows with (radius / corner radius)^2
  float exposure_target = 0.18f;     // linear mean luminance that auto-exposure aims for (18% grey)
  float exposure_strength = 0.75f;   // 0 = fixed gain 1, 1 = full correction to the target; linear in between
  float min_gain = 0.25f;            // exposure gain limits (shutter and analogue gain run out)
  float max_gain = 4.0f;
  float white_balance_strength = 0.5f;  // grey-world white balance: 0 = off, 1 = channel means made equal
  float read_noise = 1.0f;           // 8-bit levels: noise standard deviation independent of the signal
  float shot_noise = 0.12f;          // 8-bit levels^2 per level: noise variance added per level of signal (photon noise)
};

// Pose at `frame_offset` frames from frame `index` of `poses` (clamped to -1..1): translation
// interpolated linearly, rotation by normalised linear quaternion interpolation, towards the
// neighbouring frame; at either end of the sequence the missing neighbour is the frame itself (no
// motion on that side).
SE3 pose_between_frames(const std::vector<SE3>& poses, int64_t index, double frame_offset);

class ColorCamera {
 public:
  // Allocates all scratch for width x height images. `fps`: frames per second of the pose sequence
  // (the shutter time is converted to a fraction of a frame with it).
  ColorCamera(const CameraModelOptions& options, int width, int height, double fps);

  const CameraModelOptions& options() const { return o_; }

  // Renders frame `index` of `poses` through the camera: colour as the camera records it; depth,
  // labels and the renderer's incidence of the frame's own pose (the depth camera is not blurred).
  // `noise_seed` fixes the random draws; `add_noise` false leaves out the shot and read noise
  // (the deterministic effects stay). Does not allocate.
  void capture(Renderer& renderer, const std::vector<SE3>& poses, int64_t index, bool add_noise, uint64_t noise_seed,
               ImageView<Rgb8> color, ImageView<float> depth, ImageView<uint8_t> labels);

  // The last capture's exposure gain and white-balance multipliers (R, G, B), for tests and tools.
  float last_gain() const { return last_gain_; }
  const float* last_white_balance() const { return last_wb_; }

 private:
  CameraModelOptions o_;
  double fps_;
  Image<float> linear_;      // 3 floats per pixel (R, G, B interleaved, width * 3 columns): linear light summed over the shutter
  Image<float> vignette_;    // per-pixel light fraction, 1 at the principal point
  Image<Rgb8> scratch_color_;
  Image<float> scratch_depth_;
  Image<uint8_t> scratch_labels_;
  float last_gain_ = 1.0f;
  float last_wb_[3] = {1.0f, 1.0f, 1.0f};
};

}  // namespace ef::synth
