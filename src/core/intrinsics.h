// Pinhole camera intrinsics with their image size, and their scaling to other resolutions.
#pragma once

#include <Eigen/Core>

namespace ef {

// Pinhole model: pixel (u, v) = (fx * x / z + cx, fy * y / z + cy), camera frame x right, y down,
// z forward (metres). Focal lengths and principal point in pixels of a width x height image,
// pixel centres at integer coordinates.
struct Intrinsics {
  float fx = 0, fy = 0;  // focal lengths, pixels
  float cx = 0, cy = 0;  // principal point, pixels
  int width = 0, height = 0;

  bool valid() const { return fx != 0 && fy != 0 && width > 0 && height > 0; }

  // The same camera seen at another resolution (for example 640x480 -> 320x240). Pixel centres
  // map as u' = (u + 0.5) * s - 0.5, so cx' = (cx + 0.5) * sx - 0.5.
  Intrinsics scaled_to(int new_width, int new_height) const {
    const float sx = static_cast<float>(new_width) / static_cast<float>(width);
    const float sy = static_cast<float>(new_height) / static_cast<float>(height);
    return Intrinsics{fx * sx, fy * sy, (cx + 0.5f) * sx - 0.5f, (cy + 0.5f) * sy - 0.5f, new_width, new_height};
  }

  // Level `level` of an image pyramid that halves each level (level 0 = this). Sizes round down.
  // Each level scales by exactly 1/2 (pixel x of level l+1 covers pixels 2x and 2x+1 of level l),
  // also for odd sizes, where the last row or column is dropped rather than the image stretched.
  Intrinsics pyramid_level(int level) const {
    Intrinsics k = *this;
    for (int i = 0; i < level; ++i)
      k = Intrinsics{k.fx * 0.5f, k.fy * 0.5f, (k.cx + 0.5f) * 0.5f - 0.5f, (k.cy + 0.5f) * 0.5f - 0.5f, k.width / 2,
                     k.height / 2};
    return k;
  }

  // Point in the camera frame (metres) for pixel (u, v) at depth z (metres).
  Eigen::Vector3f backproject(float u, float v, float z) const {
    return Eigen::Vector3f((u - cx) * z / fx, (v - cy) * z / fy, z);
  }

  // Pixel of a camera-frame point; z must be positive.
  Eigen::Vector2f project(const Eigen::Vector3f& p) const {
    return Eigen::Vector2f(fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy);
  }
};

}  // namespace ef
