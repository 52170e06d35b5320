// The synthetic rooms' images against their own geometry: back-projection, the brute-force ray
// cast, the noise model's statistics, class coverage.
#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "core/classes.h"
#include "synth/depth_noise.h"
#include "synth/room_builder.h"
#include "synth/synthetic_source.h"
#include "test_support.h"
#include "test_synth_support.h"

namespace ef {
namespace {

using synth::Scene;

// Largest distance from a back-projected pixel (every `step`-th pixel) to the scene's surfaces.
float max_backprojection_error(const Scene& scene, const Frame& f, const Intrinsics& K, int step, int& valid) {
  float worst = 0;
  valid = 0;
  for (int y = 0; y < K.height; y += step)
    for (int x = 0; x < K.width; x += step) {
      const float z = f.depth(x, y);
      if (z <= 0) continue;
      ++valid;
      const Eigen::Vector3f pw = f.T_wc * K.backproject(static_cast<float>(x), static_cast<float>(y), z);
      worst = std::max(worst, scene.distance_to_surface(pw));
    }
  return worst;
}

TEST(SynthGeometry, ExactDepthBackProjectsOntoTheSceneWithin1mm) {
  for (const std::string& room : synthetic_room_names()) {
    for (const char* traj : {"loop", "robot"}) {
      auto src = test::open_synth("synthetic:" + room + "?noise=0&frames=300&size=320x240&trajectory=" + traj);
      ASSERT_TRUE(src);
      Frame f;
      for (int64_t i : {0, 120, 299}) {
        ASSERT_TRUE(src->render(i, f).ok());
        int valid = 0;
        const float err = max_backprojection_error(src->scene(), f, src->info().intrinsics, 3, valid);
        EXPECT_EQ(valid, 107 * 80) << room << " " << traj << " frame " << i << ": exact depth has holes";
        EXPECT_LT(err, 1e-3f) << room << " " << traj << " frame " << i;
      }
    }
  }
}

TEST(SynthGeometry, NoisyDepthStaysWithinTheModelBound) {
  // Every valid noisy depth differs from the exact one by at most the clipped Gaussian (3.47
  // sigma) plus half a disparity step.
  auto exact = test::open_synth("synthetic:living_room?noise=0&frames=100&size=320x240");
  auto noisy = test::open_synth("synthetic:living_room?noise=1&frames=100&size=320x240");
  ASSERT_TRUE(exact && noisy);
  const synth::DepthNoiseOptions o;
  Frame fe, fn;
  for (int64_t i : {10, 60}) {
    ASSERT_TRUE(exact->render(i, fe).ok());
    ASSERT_TRUE(noisy->render(i, fn).ok());
    int valid = 0, total = 0;
    for (int y = 0; y < 240; ++y)
      for (int x = 0; x < 320; ++x) {
        const float z = fe.depth(x, y), zn = fn.depth(x, y);
        ++total;
        if (zn == 0) continue;
        ++valid;
        ASSERT_GE(z, o.min_range - 0.05f);
        ASSERT_LE(z, o.max_range + 0.05f);
        const float zz = z + 3.5f * synth::depth_noise_sigma(o, z);
        const float bound = 3.47f * synth::depth_noise_sigma(o, z) + 0.51f * zz * zz / o.disparity_scale + 1e-5f;
        ASSERT_LE(std::fabs(zn - z), bound) << "pixel " << x << "," << y << " z " << z;
        // And the back-projected noisy point is that close to a surface.
      }
    EXPECT_GT(valid, total / 2) << "frame " << i << ": too much dropout";
    EXPECT_LT(valid, total) << "frame " << i << ": no dropout at all";
  }
}

TEST(SynthGeometry, NoiseStatisticsMatchTheModel) {
  // Depth residuals in bins of depth: their standard deviation is sqrt(sigma^2 + step^2 / 12).
  auto exact = test::open_synth("synthetic:library?noise=0&frames=300&size=320x240");
  auto noisy = test::open_synth("synthetic:library?noise=1&frames=300&size=320x240");
  ASSERT_TRUE(exact && noisy);
  const synth::DepthNoiseOptions o;
  struct Bin { double sum2 = 0, expected = 0; int n = 0; };
  Bin bins[4];  // [0.5,1.5), [1.5,2.5), [2.5,3.5), [3.5,4.5)
  Frame fe, fn;
  long color_n = 0;
  double color_sum2 = 0;
  for (int64_t i = 0; i < 300; i += 50) {
    ASSERT_TRUE(exact->render(i, fe).ok());
    ASSERT_TRUE(noisy->render(i, fn).ok());
    for (int y = 0; y < 240; ++y)
      for (int x = 0; x < 320; ++x) {
        const float z = fe.depth(x, y), zn = fn.depth(x, y);
        const Rgb8 a = fe.color(x, y), b = fn.color(x, y);
        if (a.g > 8 && a.g < 247) {
          color_sum2 += (double(b.g) - a.g) * (double(b.g) - a.g);
          ++color_n;
        }
        if (zn == 0 || z < 0.5f) continue;
        const int k = static_cast<int>(z - 0.5f);
        if (k > 3) continue;
        const double s = synth::depth_noise_sigma(o, z), q = z * z / o.disparity_scale;
        bins[k].sum2 += double(zn - z) * (zn - z);
        bins[k].expected += s * s + q * q / 12;
        ++bins[k].n;
      }
  }
  int checked = 0;
  for (const Bin& b : bins) {
    if (b.n < 2000) continue;
    ++checked;
    const double ratio = std::sqrt(b.sum2 / b.expected);
    EXPECT_NEAR(ratio, 1.0, 0.15) << "bin with " << b.n << " pixels";
  }
  EXPECT_GE(checked, 2);
  EXPECT_NEAR(std::sqrt(color_sum2 / color_n), o.color_sigma, 0.3);
}

TEST(SynthGeometry, QuantisationStepGrowsWithDepthSquared) {
  const synth::DepthNoiseOptions o;
  // Distinct quantised depths near 1 m are ~2.9 mm apart, near 4 m ~4.6 cm.
  const float a = synth::quantise_depth(o, 1.0f), b = synth::quantise_depth(o, 1.0f + 0.003f);
  EXPECT_NEAR(b - a, 1.0f / o.disparity_scale, 0.0005f);
  const float c = synth::quantise_depth(o, 4.0f), d = synth::quantise_depth(o, 4.0f + 0.047f);
  EXPECT_NEAR(d - c, 16.0f / o.disparity_scale, 0.003f);
  EXPECT_NEAR(synth::depth_noise_sigma(o, 0.4f), 0.0012f, 1e-6f);
  EXPECT_NEAR(synth::depth_noise_sigma(o, 3.4f), 0.0012f + 0.0019f * 9, 1e-6f);
}

TEST(SynthGeometry, RendererAgreesWithBruteForceRayCast) {
  auto src = test::open_synth("synthetic:office?noise=0&frames=200&size=160x120");
  ASSERT_TRUE(src);
  const Intrinsics& K = src->info().intrinsics;
  Frame f;
  int mismatched = 0, total = 0;
  for (int64_t i : {0, 70, 140}) {
    ASSERT_TRUE(src->render(i, f).ok());
    const Eigen::Vector3f o = f.T_wc.translation().cast<float>();
    const Eigen::Matrix3f R = f.T_wc.rotation_matrix().cast<float>();
    for (int y = 0; y < K.height; y += 2)
      for (int x = 0; x < K.width; x += 2) {
        const Eigen::Vector3f d = R * Eigen::Vector3f((x - K.cx) / K.fx, (y - K.cy) / K.fy, 1.0f);
        synth::Hit hit;
        ASSERT_TRUE(src->scene().raycast(o, d, hit));
        ++total;
        EXPECT_NEAR(hit.t, f.depth(x, y), 1e-4f);
        mismatched += hit.label != f.labels(x, y);
      }
  }
  EXPECT_LE(mismatched, total / 1000);  // ties on coincident faces only
}

TEST(SynthGeometry, BuiltInRoomsContainAll13Classes) {
  if (test::kUnderEmulator) GTEST_SKIP() << test::kLongSequenceTestUnderEmulator;
  // In the scene descriptions...
  std::vector<bool> described(kNumClassesWithUnknown, false);
  for (const std::string& room : synthetic_room_names()) {
    auto scene = synth::build_room(room, 0);
    ASSERT_TRUE(scene.ok());
    const auto present = scene->classes_present();
    for (int c = 0; c < kNumClassesWithUnknown; ++c) described[c] = described[c] || present[c];
  }
  for (int c = 1; c <= kNumClasses; ++c) EXPECT_TRUE(described[c]) << "no " << class_name(c) << " in any room";
  // ...and in the rendered labels along the default trajectories.
  std::vector<long> pixels(kNumClassesWithUnknown, 0);
  for (const std::string& room : synthetic_room_names()) {
    for (const char* traj : {"loop", "robot"}) {
      auto src = test::open_synth("synthetic:" + room + "?noise=0&size=160x120&trajectory=" + traj);
      ASSERT_TRUE(src);
      Frame f;
      for (int64_t i = 0; i < 300; i += 15) {
        ASSERT_TRUE(src->render(i, f).ok());
        for (std::size_t p = 0; p < f.labels.size(); ++p) ++pixels[f.labels.data()[p]];
      }
    }
  }
  EXPECT_EQ(pixels[kUnknown], 0);
  for (int c = 1; c <= kNumClasses; ++c) EXPECT_GT(pixels[c], 200) << class_name(c) << " barely seen";
  for (int c = 1; c <= kNumClasses; ++c) std::printf("  %-10s %ld px\n", std::string(class_name(c)).c_str(), pixels[c]);
}

TEST(SynthGeometry, TexturesHavePhotometricGradients) {
  // Share of pixels whose horizontal or vertical intensity gradient exceeds 4 levels: trackers
  // need texture, not flat walls.
  for (const std::string& room : synthetic_room_names()) {
    auto src = test::open_synth("synthetic:" + room + "?noise=0&frames=300&size=320x240");
    ASSERT_TRUE(src);
    Frame f;
    for (int64_t i : {0, 150}) {
      ASSERT_TRUE(src->render(i, f).ok());
      int strong = 0, n = 0;
      for (int y = 1; y < 240; ++y)
        for (int x = 1; x < 320; ++x, ++n) {
          const auto I = [&](int u, int v) { const Rgb8 c = f.color(u, v); return int(c.r) + 2 * c.g + c.b; };
          strong += std::abs(I(x, y) - I(x - 1, y)) > 16 || std::abs(I(x, y) - I(x, y - 1)) > 16;
        }
      EXPECT_GT(strong, n / 20) << room << " frame " << i;
    }
  }
}

}  // namespace
}  // namespace ef
