#include "synth/camera_model.h"

#include <algorithm>
#include <cmath>

#include "synth/rng.h"

namespace ef::synth {

namespace {

// Written out component by component (not Eigen expressions): Eigen may evaluate these with fused
// multiply-adds on ARM64 whatever -ffp-contract says, and the images must match across machines.
SE3 interpolate(const SE3& a, const SE3& b, double t) {
  const Eigen::Quaterniond& qa = a.rotation();
  Eigen::Quaterniond qb = b.rotation();
  const double d = qa.w() * qb.w() + qa.x() * qb.x() + qa.y() * qb.y() + qa.z() * qb.z();
  const double sb = d < 0 ? -t : t;  // the shorter way round
  const double sa = 1.0 - t;
  const Eigen::Quaterniond q(sa * qa.w() + sb * qb.w(), sa * qa.x() + sb * qb.x(), sa * qa.y() + sb * qb.y(),
                             sa * qa.z() + sb * qb.z());
  const Eigen::Vector3d& ta = a.translation();
  const Eigen::Vector3d& tb = b.translation();
  const Eigen::Vector3d tr(sa * ta.x() + t * tb.x(), sa * ta.y() + t * tb.y(), sa * ta.z() + t * tb.z());
  return SE3(q, tr);  // SE3 normalises q
}

}  // namespace

SE3 pose_between_frames(const std::vector<SE3>& poses, int64_t index, double frame_offset) {
  const int64_t n = static_cast<int64_t>(poses.size());
  if (frame_offset == 0.0) return poses[index];
  const int64_t other = frame_offset < 0 ? index - 1 : index + 1;
  if (other < 0 || other >= n) return poses[index];
  return interpolate(poses[index], poses[other], std::min(1.0, std::fabs(frame_offset)));
}

ColorCamera::ColorCamera(const CameraModelOptions& options, int width, int height, double fps)
    : o_(options), fps_(fps) {
  o_.blur_samples = std::max(1, o_.blur_samples) | 1;  // odd: the middle sample is the frame's own pose
  linear_.allocate(3 * width, height);
  vignette_.allocate(width, height);
  scratch_color_.allocate(width, height);
  scratch_depth_.allocate(width, height);
  scratch_labels_.allocate(width, height);
  // Radial fall-off about the image centre: 1 - vignetting * r^2 / r_corner^2.
  const float cx = 0.5f * static_cast<float>(width - 1), cy = 0.5f * static_cast<float>(height - 1);
  const float r2_corner = cx * cx + cy * cy;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float dx = static_cast<float>(x) - cx, dy = static_cast<float>(y) - cy;
      const float r2 = dx * dx + dy * dy;
      vignette_(x, y) = r2_corner > 0.0f ? 1.0f - o_.vignetting * (r2 / r2_corner) : 1.0f;
    }
}

void ColorCamera::capture(Renderer& renderer, const std::vector<SE3>& poses, int64_t index, bool add_noise,
                          uint64_t noise_seed, ImageView<Rgb8> color, ImageView<float> depth,
                          ImageView<uint8_t> labels) {
  const int w = color.width, h = color.height;
  ImageView<float> lin = linear_.view();
  for (int y = 0; y < h; ++y) std::fill(lin.row(y), lin.row(y) + 3 * w, 0.0f);

  // 1. Motion blur: the mean of the linear light of renders spread evenly over the shutter, the
  // frame's own pose last (it leaves the depth, labels and incidence of the frame's pose).
  const int samples = o_.blur_samples;
  const double shutter_frames = static_cast<double>(o_.shutter_s) * fps_;
  for (int s = 0; s < samples; ++s) {
    const int k = s == samples - 1 ? samples / 2 : (s < samples / 2 ? s : s + 1);  // middle sample last
    const double offset = samples > 1 ? (static_cast<double>(k) / (samples - 1) - 0.5) * shutter_frames : 0.0;
    const bool last = s == samples - 1;
    ImageView<Rgb8> c = last ? color : scratch_color_.view();
    renderer.render(pose_between_frames(poses, index, offset), c, last ? depth : scratch_depth_.view(),
                    last ? labels : scratch_labels_.view());
    for (int y = 0; y < h; ++y) {
      const Rgb8* crow = c.row(y);
      float* lrow = lin.row(y);
      for (int x = 0; x < w; ++x) {
        lrow[3 * x + 0] += levels_to_linear(crow[x].r);
        lrow[3 * x + 1] += levels_to_linear(crow[x].g);
        lrow[3 * x + 2] += levels_to_linear(crow[x].b);
      }
    }
  }

  // 2. Vignetting, and the channel means that exposure and white balance measure (the camera
  // meters what reaches the sensor, vignetting included).
  const float inv_samples = 1.0f / static_cast<float>(samples);
  double sum[3] = {0.0, 0.0, 0.0};
  for (int y = 0; y < h; ++y) {
    float* lrow = lin.row(y);
    const float* vrow = vignette_.view().row(y);
    double row_sum[3] = {0.0, 0.0, 0.0};
    for (int x = 0; x < w; ++x)
      for (int ch = 0; ch < 3; ++ch) {
        const float v = lrow[3 * x + ch] * inv_samples * vrow[x];
        lrow[3 * x + ch] = v;
        row_sum[ch] += v;
      }
    for (int ch = 0; ch < 3; ++ch) sum[ch] += row_sum[ch];
  }
  const double pixels = static_cast<double>(w) * h;
  const float mean[3] = {static_cast<float>(sum[0] / pixels), static_cast<float>(sum[1] / pixels),
                         static_cast<float>(sum[2] / pixels)};

  // 3. Auto-exposure (towards the target luminance, partly, within the gain limits) and grey-world
  // white balance (towards equal channel means, partly).
  const float luminance = 0.25f * mean[0] + 0.5f * mean[1] + 0.25f * mean[2];
  const float full_gain = o_.exposure_target / std::max(luminance, 1e-6f);
  last_gain_ = std::min(o_.max_gain, std::max(o_.min_gain, 1.0f + o_.exposure_strength * (full_gain - 1.0f)));
  const float grey = (mean[0] + mean[1] + mean[2]) * (1.0f / 3.0f);
  float scale[3];
  for (int ch = 0; ch < 3; ++ch) {
    const float full_wb = grey / std::max(mean[ch], 1e-6f);
    last_wb_[ch] = 1.0f + o_.white_balance_strength * (full_wb - 1.0f);
    scale[ch] = last_gain_ * last_wb_[ch];
  }

  // 4. Gain, clipping at full well (linear_to_levels clamps to 1), back to 8 bits, shot and read noise.
  Pcg32 rng(noise_seed, 0x63616d6572613031ULL);
  const float read_var = o_.read_noise * o_.read_noise;
  for (int y = 0; y < h; ++y) {
    const float* lrow = lin.row(y);
    Rgb8* crow = color.row(y);
    for (int x = 0; x < w; ++x) {
      uint8_t out[3];
      for (int ch = 0; ch < 3; ++ch) {
        float v = linear_to_levels(lrow[3 * x + ch] * scale[ch]);
        if (add_noise) v += std::sqrt(read_var + o_.shot_noise * v) * rng.gaussian();
        out[ch] = static_cast<uint8_t>(std::min(255.0f, std::max(0.0f, std::nearbyint(v))));
      }
      crow[x] = Rgb8{out[0], out[1], out[2]};
    }
  }
}

}  // namespace ef::synth
