#include <gtest/gtest.h>

#include <random>

#include "core/intrinsics.h"

namespace ef {
namespace {

// The TUM fr1 colour camera (640x480).
Intrinsics tum_fr1() { return Intrinsics{517.3f, 516.5f, 318.6f, 255.3f, 640, 480}; }

TEST(Intrinsics, Valid) {
  EXPECT_TRUE(tum_fr1().valid());
  EXPECT_FALSE(Intrinsics{}.valid());
  Intrinsics k = tum_fr1();
  k.width = 0;
  EXPECT_FALSE(k.valid());
  k = tum_fr1();
  k.fy = 0;
  EXPECT_FALSE(k.valid());
}

TEST(Intrinsics, ProjectAndBackprojectAreInverse) {
  const Intrinsics k = tum_fr1();
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-20.0f, 660.0f), v(-20.0f, 500.0f), z(0.1f, 8.0f);
  for (int i = 0; i < 1000; ++i) {
    const float pu = u(rng), pv = v(rng), pz = z(rng);
    const Eigen::Vector3f p = k.backproject(pu, pv, pz);
    EXPECT_FLOAT_EQ(p.z(), pz);
    const Eigen::Vector2f q = k.project(p);
    EXPECT_NEAR(q.x(), pu, 2e-4f);
    EXPECT_NEAR(q.y(), pv, 2e-4f);
  }
  // The principal point is on the optical axis.
  const Eigen::Vector3f axis = k.backproject(k.cx, k.cy, 2.0f);
  EXPECT_FLOAT_EQ(axis.x(), 0.0f);
  EXPECT_FLOAT_EQ(axis.y(), 0.0f);
  // A known point: 1 m to the right at 2 m depth lands fx/2 to the right of cx.
  const Eigen::Vector2f q = k.project(Eigen::Vector3f(1.0f, -0.5f, 2.0f));
  EXPECT_FLOAT_EQ(q.x(), k.cx + k.fx / 2);
  EXPECT_FLOAT_EQ(q.y(), k.cy - k.fy / 4);
}

TEST(Intrinsics, ScaledToMapsPixelCentres) {
  const Intrinsics k = tum_fr1();
  const Intrinsics s = k.scaled_to(320, 240);
  EXPECT_EQ(s.width, 320);
  EXPECT_EQ(s.height, 240);
  EXPECT_FLOAT_EQ(s.fx, k.fx / 2);
  EXPECT_FLOAT_EQ(s.fy, k.fy / 2);
  EXPECT_FLOAT_EQ(s.cx, (k.cx + 0.5f) / 2 - 0.5f);
  EXPECT_FLOAT_EQ(s.cy, (k.cy + 0.5f) / 2 - 0.5f);

  // Any 3D point projects to the same place in image-extent coordinates: u' = (u + 0.5) * s - 0.5.
  const Intrinsics up = k.scaled_to(1000, 600);  // non-uniform, non-integer scales
  const float sx = 1000.0f / 640.0f, sy = 600.0f / 480.0f;
  for (const Eigen::Vector3f& p : {Eigen::Vector3f(0.3f, -0.2f, 1.5f), Eigen::Vector3f(-1.0f, 0.7f, 3.0f)}) {
    const Eigen::Vector2f a = k.project(p), b = up.project(p);
    EXPECT_NEAR(b.x(), (a.x() + 0.5f) * sx - 0.5f, 1e-3f);
    EXPECT_NEAR(b.y(), (a.y() + 0.5f) * sy - 0.5f, 1e-3f);
  }
  // The image corners (pixel edges at -0.5 and w-0.5) map onto each other.
  const Intrinsics back = up.scaled_to(640, 480);
  EXPECT_NEAR(back.cx, k.cx, 1e-3f);
  EXPECT_NEAR(back.fx, k.fx, 1e-3f);
}

TEST(Intrinsics, PyramidLevelHalvesPixelCoordinates) {
  const Intrinsics k0 = tum_fr1();
  EXPECT_EQ(k0.pyramid_level(0).fx, k0.fx);
  EXPECT_EQ(k0.pyramid_level(0).cx, k0.cx);
  const Intrinsics k1 = k0.pyramid_level(1);
  EXPECT_EQ(k1.width, 320);
  EXPECT_EQ(k1.height, 240);
  const Intrinsics k2 = k0.pyramid_level(2);
  EXPECT_EQ(k2.width, 160);
  EXPECT_EQ(k2.height, 120);
  for (const Eigen::Vector3f& p : {Eigen::Vector3f(0.3f, -0.2f, 1.5f), Eigen::Vector3f(-1.0f, 0.7f, 3.0f),
                                   Eigen::Vector3f(0.0f, 0.0f, 1.0f)}) {
    const Eigen::Vector2f u0 = k0.project(p), u1 = k1.project(p), u2 = k2.project(p);
    EXPECT_NEAR(u1.x(), (u0.x() + 0.5f) / 2 - 0.5f, 1e-4f);
    EXPECT_NEAR(u1.y(), (u0.y() + 0.5f) / 2 - 0.5f, 1e-4f);
    EXPECT_NEAR(u2.x(), (u1.x() + 0.5f) / 2 - 0.5f, 1e-4f);
    EXPECT_NEAR(u2.y(), (u1.y() + 0.5f) / 2 - 0.5f, 1e-4f);
  }
}

TEST(Intrinsics, PyramidLevelOfOddSizeStillHalvesExactly) {
  // A 2x2-block pyramid of an odd-sized image drops the last row/column; the pixels that remain
  // still map by exactly a factor of two: level-1 pixel x covers level-0 pixels 2x and 2x+1.
  const Intrinsics k0{300.0f, 301.0f, 211.3f, 119.7f, 425, 241};
  const Intrinsics k1 = k0.pyramid_level(1);
  EXPECT_EQ(k1.width, 212);
  EXPECT_EQ(k1.height, 120);
  EXPECT_FLOAT_EQ(k1.fx, k0.fx / 2);
  EXPECT_FLOAT_EQ(k1.fy, k0.fy / 2);
  EXPECT_FLOAT_EQ(k1.cx, (k0.cx + 0.5f) / 2 - 0.5f);
  EXPECT_FLOAT_EQ(k1.cy, (k0.cy + 0.5f) / 2 - 0.5f);
  const Intrinsics k3 = k0.pyramid_level(3);
  EXPECT_EQ(k3.width, 53);
  EXPECT_EQ(k3.height, 30);
  EXPECT_FLOAT_EQ(k3.fx, k0.fx / 8);
  const Eigen::Vector3f p(0.4f, 0.1f, 2.0f);
  const Eigen::Vector2f u0 = k0.project(p), u3 = k3.project(p);
  EXPECT_NEAR(u3.x(), (u0.x() + 0.5f) / 8 - 0.5f, 1e-4f);
  EXPECT_NEAR(u3.y(), (u0.y() + 0.5f) / 8 - 0.5f, 1e-4f);
}

}  // namespace
}  // namespace ef
