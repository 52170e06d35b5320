// The synthetic colour camera (camera_model.h): pose interpolation over the shutter, an exact round
// trip when every effect is off, exposure and white balance against their closed form, motion blur
// along the motion, noise variance against its model, and the source's camera=kinect option.
#include <cmath>
#include <cstring>

#include <gtest/gtest.h>

#include "synth/camera_model.h"
#include "synth/room_builder.h"
#include "test_synth_support.h"

namespace ef {
namespace {

using synth::CameraModelOptions;
using synth::ColorCamera;
using synth::Scene;

// A pan: the camera turns about its own y axis by `deg_per_frame` degrees per frame, standing
// still at the room's middle at 1.4 m, looking along +x (camera z = world x, camera y = world -z).
std::vector<SE3> pan(const Scene& scene, int frames, double deg_per_frame) {
  Eigen::Matrix3d look;
  look << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const Eigen::Vector3d centre(0.5 * scene.size.x(), 0.5 * scene.size.y(), 1.4);
  std::vector<SE3> poses;
  for (int i = 0; i < frames; ++i) {
    const Eigen::Matrix3d yaw =
        Eigen::AngleAxisd(i * deg_per_frame * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    poses.emplace_back(Eigen::Matrix3d(yaw * look), centre);
  }
  return poses;
}

struct Rig {
  Scene scene;
  Intrinsics K = synthetic_default_intrinsics().scaled_to(160, 120);
  std::unique_ptr<synth::Renderer> renderer;
  Image<Rgb8> color{160, 120}, ideal{160, 120};
  Image<float> depth{160, 120};
  Image<uint8_t> labels{160, 120};

  Rig() {
    auto s = synth::build_room("office", 0);
    EXPECT_TRUE(s.ok());
    scene = std::move(s).value();
    renderer = std::make_unique<synth::Renderer>(scene, K);
  }
  void render_ideal(const SE3& pose) { renderer->render(pose, ideal.view(), depth.view(), labels.view()); }
};

CameraModelOptions effects_off() {
  CameraModelOptions o;
  o.vignetting = 0.0f;
  o.exposure_strength = 0.0f;
  o.white_balance_strength = 0.0f;
  return o;
}

float lin(uint8_t v) {
  const float c = static_cast<float>(v) / 255.0f;
  return c * c;
}

TEST(CameraModel, PoseBetweenFramesInterpolatesTowardsTheNeighbour) {
  Rig rig;
  const std::vector<SE3> poses = pan(rig.scene, 3, 2.0);
  auto angle = [](const SE3& a, const SE3& b) { return a.rotation().angularDistance(b.rotation()) * 180.0 / M_PI; };
  EXPECT_NEAR(angle(synth::pose_between_frames(poses, 1, 0.0), poses[1]), 0.0, 1e-9);
  EXPECT_NEAR(angle(synth::pose_between_frames(poses, 1, 1.0), poses[2]), 0.0, 1e-6);
  EXPECT_NEAR(angle(synth::pose_between_frames(poses, 1, -1.0), poses[0]), 0.0, 1e-6);
  EXPECT_NEAR(angle(synth::pose_between_frames(poses, 1, 0.5), poses[1]), 1.0, 1e-4);
  EXPECT_NEAR(angle(synth::pose_between_frames(poses, 1, -0.25), poses[0]), 1.5, 1e-4);
  // Offsets beyond a neighbour stop at it (a shutter longer than two frames).
  EXPECT_NEAR(angle(synth::pose_between_frames(poses, 1, 1.5), poses[2]), 0.0, 1e-6);
  // No neighbour before frame 0 or after the last: no motion on that side.
  EXPECT_NEAR(angle(synth::pose_between_frames(poses, 0, -0.3), poses[0]), 0.0, 1e-9);
  EXPECT_NEAR(angle(synth::pose_between_frames(poses, 2, 0.3), poses[2]), 0.0, 1e-9);
}

TEST(CameraModel, WithoutMotionAndEffectsTheImageIsTheRenderersExactly) {
  Rig rig;
  const std::vector<SE3> poses(3, pan(rig.scene, 1, 0.0)[0]);
  ColorCamera camera(effects_off(), 160, 120, 30.0);
  camera.capture(*rig.renderer, poses, 1, false, 0, rig.color.view(), rig.depth.view(), rig.labels.view());
  rig.render_ideal(poses[1]);
  EXPECT_EQ(std::memcmp(rig.color.data(), rig.ideal.data(), rig.color.size() * sizeof(Rgb8)), 0);
  EXPECT_FLOAT_EQ(camera.last_gain(), 1.0f);
}

TEST(CameraModel, ExposureAndWhiteBalanceFollowTheirClosedForm) {
  Rig rig;
  const std::vector<SE3> poses = pan(rig.scene, 1, 0.0);
  CameraModelOptions o;
  o.blur_samples = 1;
  o.vignetting = 0.0f;
  ColorCamera camera(o, 160, 120, 30.0);
  camera.capture(*rig.renderer, poses, 0, false, 0, rig.color.view(), rig.depth.view(), rig.labels.view());
  rig.render_ideal(poses[0]);
  double sum[3] = {0, 0, 0};
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) {
      sum[0] += lin(rig.ideal(x, y).r);
      sum[1] += lin(rig.ideal(x, y).g);
      sum[2] += lin(rig.ideal(x, y).b);
    }
  const double n = 160.0 * 120.0;
  const double m[3] = {sum[0] / n, sum[1] / n, sum[2] / n};
  const double lum = 0.25 * m[0] + 0.5 * m[1] + 0.25 * m[2];
  const double gain = std::clamp(1.0 + o.exposure_strength * (o.exposure_target / lum - 1.0),
                                 double{o.min_gain}, double{o.max_gain});
  EXPECT_NEAR(camera.last_gain(), gain, 1e-4 * gain);
  const double grey = (m[0] + m[1] + m[2]) / 3.0;
  for (int ch = 0; ch < 3; ++ch)
    EXPECT_NEAR(camera.last_white_balance()[ch], 1.0 + o.white_balance_strength * (grey / m[ch] - 1.0), 1e-4);
  // The office is brighter than the target: the camera darkens it, within the gain limits.
  EXPECT_LT(camera.last_gain(), 1.0f);
  // Every pixel: gamma-2 levels of linear x gain x white balance, clipped at full scale (to the
  // rounding of the float path: at most one level).
  int worst = 0;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) {
      const uint8_t in[3] = {rig.ideal(x, y).r, rig.ideal(x, y).g, rig.ideal(x, y).b};
      const uint8_t out[3] = {rig.color(x, y).r, rig.color(x, y).g, rig.color(x, y).b};
      for (int ch = 0; ch < 3; ++ch) {
        const double v = std::min(1.0, lin(in[ch]) * gain * camera.last_white_balance()[ch]);
        worst = std::max(worst, std::abs(static_cast<int>(std::lround(std::sqrt(v) * 255.0)) - out[ch]));
      }
    }
  EXPECT_LE(worst, 1);
}

// Sum of squared differences between horizontal (dx) or vertical (dx = false) neighbours.
double gradient_energy(const Image<Rgb8>& im, bool horizontal) {
  double e = 0;
  for (int y = 0; y + 1 < im.height(); ++y)
    for (int x = 0; x + 1 < im.width(); ++x) {
      const Rgb8 a = im.view()(x, y), b = horizontal ? im.view()(x + 1, y) : im.view()(x, y + 1);
      const double d = (a.r + a.g + a.b) - (b.r + b.g + b.b);
      e += d * d;
    }
  return e;
}

TEST(CameraModel, MotionBlurSmearsAlongTheMotion) {
  Rig rig;
  // 3 degrees per frame: with the default 20 ms shutter at 30 Hz the image moves about 4.5 pixels
  // (160 pixels over 2 x atan(80 / 131.25) = 62 degrees) while the shutter is open.
  const std::vector<SE3> poses = pan(rig.scene, 3, 3.0);
  ColorCamera sharp([] { auto o = effects_off(); o.blur_samples = 1; return o; }(), 160, 120, 30.0);
  ColorCamera blurred(effects_off(), 160, 120, 30.0);
  Image<Rgb8> sharp_image(160, 120);
  sharp.capture(*rig.renderer, poses, 1, false, 0, sharp_image.view(), rig.depth.view(), rig.labels.view());
  blurred.capture(*rig.renderer, poses, 1, false, 0, rig.color.view(), rig.depth.view(), rig.labels.view());
  const double h_ratio = gradient_energy(rig.color, true) / gradient_energy(sharp_image, true);
  const double v_ratio = gradient_energy(rig.color, false) / gradient_energy(sharp_image, false);
  // Measured: 0.12 across the motion, 0.57 along it (fine texture is averaged along the motion,
  // which lowers its vertical contrast too, but far less).
  EXPECT_LT(h_ratio, 0.5) << "horizontal detail should be smeared by the pan";
  EXPECT_LT(h_ratio, 0.5 * v_ratio) << "a horizontal pan should smear horizontal detail most";
  // Depth and labels are those of the frame's own pose.
  Image<float> depth(160, 120);
  Image<uint8_t> labels(160, 120);
  rig.renderer->render(poses[1], rig.ideal.view(), depth.view(), labels.view());
  EXPECT_EQ(std::memcmp(depth.data(), rig.depth.data(), depth.size() * sizeof(float)), 0);
  EXPECT_EQ(std::memcmp(labels.data(), rig.labels.data(), labels.size()), 0);
}

TEST(CameraModel, NoiseVarianceFollowsReadPlusShotNoise) {
  Rig rig;
  const std::vector<SE3> poses = pan(rig.scene, 1, 0.0);
  CameraModelOptions o = effects_off();
  o.blur_samples = 1;
  ColorCamera camera(o, 160, 120, 30.0);
  Image<Rgb8> clean(160, 120);
  camera.capture(*rig.renderer, poses, 0, false, 0, clean.view(), rig.depth.view(), rig.labels.view());
  // Noise residuals over many seeds, binned by the clean level: dark (< 100) and bright (>= 150).
  double sq[2] = {0, 0}, level[2] = {0, 0};
  long count[2] = {0, 0};
  for (uint64_t seed = 1; seed <= 8; ++seed) {
    camera.capture(*rig.renderer, poses, 0, true, seed, rig.color.view(), rig.depth.view(), rig.labels.view());
    for (int y = 0; y < 120; ++y)
      for (int x = 0; x < 160; ++x) {
        const int c = clean(x, y).g, v = rig.color(x, y).g;
        if (c < 20 || c > 235) continue;  // away from clipping at 0 and 255
        const int bin = c < 100 ? 0 : (c >= 150 ? 1 : -1);
        if (bin < 0) continue;
        sq[bin] += (v - c) * (v - c);
        level[bin] += c;
        ++count[bin];
      }
  }
  for (int bin = 0; bin < 2; ++bin) {
    ASSERT_GT(count[bin], 1000) << "bin " << bin;
    const double mean_level = level[bin] / count[bin];
    const double expected = o.read_noise * o.read_noise + o.shot_noise * mean_level + 1.0 / 12.0;  // + rounding
    EXPECT_NEAR(sq[bin] / count[bin], expected, 0.12 * expected) << "bin " << bin << " at level " << mean_level;
  }
  EXPECT_GT(sq[1] / count[1], 1.5 * sq[0] / count[0]) << "brighter pixels are noisier";
}

TEST(CameraModel, KinectCameraOptionIsDeterministicAndDoesNotReallocate) {
  const char* text = "synthetic:random?seed=7&frames=12&size=160x120&camera=kinect";
  auto a = test::open_synth(text);
  auto b = test::open_synth(text);
  auto ideal = test::open_synth("synthetic:random?seed=7&frames=12&size=160x120");
  ASSERT_TRUE(a && b && ideal);
  EXPECT_TRUE(a->options().camera == synth::CameraKind::kKinect);
  Frame fa, fb, fi;
  ASSERT_TRUE(a->render(9, fa).ok());
  ASSERT_TRUE(b->render(3, fb).ok());  // out of order: per-frame noise streams
  ASSERT_TRUE(b->render(9, fb).ok());
  ASSERT_TRUE(ideal->render(9, fi).ok());
  EXPECT_EQ(std::memcmp(fa.color.data(), fb.color.data(), fa.color.size() * sizeof(Rgb8)), 0);
  EXPECT_NE(std::memcmp(fa.color.data(), fi.color.data(), fa.color.size() * sizeof(Rgb8)), 0);
  // Depth and labels are the ideal camera's (the depth noise stream is the same).
  EXPECT_EQ(std::memcmp(fa.depth.data(), fi.depth.data(), fa.depth.size() * sizeof(float)), 0);
  EXPECT_EQ(std::memcmp(fa.labels.data(), fi.labels.data(), fa.labels.size()), 0);
  const void* c = fa.color.data();
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(*a->next(fa));
  EXPECT_EQ(c, fa.color.data());
}

TEST(CameraModel, UnknownCameraIsAnErrorNamingIt) {
  auto uri = parse_source_uri("synthetic:?camera=gopro");
  ASSERT_TRUE(uri.ok());
  auto o = synth::parse_synthetic_options(*uri);
  ASSERT_FALSE(o.ok());
  EXPECT_NE(o.error().message.find("gopro"), std::string::npos);
  EXPECT_NE(o.error().message.find("camera"), std::string::npos);
}

}  // namespace
}  // namespace ef
