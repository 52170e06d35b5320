// Synthetic depth for the preprocessing tests: planes rendered analytically (exact ray-plane
// intersections), optional Gaussian noise and step edges.
#pragma once

#include <cmath>
#include <random>

#include <Eigen/Core>

#include "core/frame.h"
#include "core/intrinsics.h"

namespace ef::test {

// 7-Scenes / Kinect intrinsics (585 px at 640x480) at 320x240.
inline Intrinsics kinect_320x240() { return Intrinsics{585, 585, 320, 240, 640, 480}.scaled_to(320, 240); }

// Depth (metres along z) of the plane {X : n . X = d} seen through pixel (u, v); 0 when the ray misses
// it (behind the camera).
inline float plane_depth(const Intrinsics& K, const Eigen::Vector3d& n, double d, double u, double v) {
  const Eigen::Vector3d ray((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
  const double denom = n.dot(ray);
  if (std::fabs(denom) < 1e-12) return 0.0f;
  const double z = d / denom;
  return z > 0 ? static_cast<float>(z) : 0.0f;
}

// A plane through (0, 0, z0) whose normal is the optical axis tilted by `tilt_x_deg` about x and
// `tilt_y_deg` about y; returns the unit normal pointing toward the camera.
inline Eigen::Vector3d render_plane(Frame& f, const Intrinsics& K, double z0, double tilt_x_deg, double tilt_y_deg) {
  const double ax = tilt_x_deg * M_PI / 180, ay = tilt_y_deg * M_PI / 180;
  const Eigen::Vector3d n = Eigen::Vector3d(std::sin(ay) * std::cos(ax), std::sin(ax), std::cos(ay) * std::cos(ax)).normalized();
  const double d = n.z() * z0;
  f.allocate(K.width, K.height, false);
  for (int y = 0; y < K.height; ++y)
    for (int x = 0; x < K.width; ++x) f.depth(x, y) = plane_depth(K, n, d, x, y);
  f.color.fill(Rgb8{128, 128, 128});
  return -n;  // toward the camera (n . X = d > 0 on the plane)
}

inline void add_noise(Image<float>& depth, float sigma_m, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> g(0.0f, sigma_m);
  for (int y = 0; y < depth.height(); ++y)
    for (int x = 0; x < depth.width(); ++x)
      if (depth(x, y) > 0) depth(x, y) += g(rng);
}

}  // namespace ef::test
