// The vertex and normal maps of slam/vertex_normal.h.
#include "slam/vertex_normal.h"

#include <cstdint>
#include <cstring>

#include "kernels/normal_row.h"

namespace ef::slam {

namespace {

// `value` where `keep`, else +0.0f, by a bit mask: GCC turns a select whose arm alone uses a
// division into a branch around the stores, which it does not vectorise; the mask form it does.
inline float keep_if(bool keep, float value) {
  uint32_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  bits &= 0u - static_cast<uint32_t>(keep);
  float out;
  std::memcpy(&out, &bits, sizeof out);
  return out;
}

}  // namespace

void vertex_normal_maps(const Image<float>& depth, const Intrinsics& K, float step_x, float step_y, bool divide,
                        Image<Eigen::Vector3f>& vertex, Image<Eigen::Vector3f>& normal) {
  const int w = K.width, h = K.height;
  const Eigen::Vector3f zero = Eigen::Vector3f::Zero();
  // The vertices: branch-free over a row (every value computed, then selects), reading and writing
  // the vectors component by component, so that the compiler vectorises it.
  for (int y = 0; y < h; ++y) {
    const float* d = depth.data() + static_cast<std::size_t>(y) * w;
    float* v = vertex.data()[static_cast<std::size_t>(y) * w].data();  // x, y, z per pixel
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector3f p = K.backproject(static_cast<float>(x), static_cast<float>(y), d[x]);
      const bool valid = d[x] > 0.0f;
      v[3 * x] = keep_if(valid, p.x());
      v[3 * x + 1] = keep_if(valid, p.y());
      v[3 * x + 2] = keep_if(valid, p.z());
    }
  }
  kernels::NormalRow row;
  row.step_x = step_x;
  row.step_y = step_y;
  row.divide = divide;
  for (int y = 0; y < h; ++y) {
    Eigen::Vector3f* n = normal.data() + static_cast<std::size_t>(y) * w;
    if (y == 0 || y == h - 1 || w < 3) {
      for (int x = 0; x < w; ++x) n[x] = zero;
      continue;
    }
    for (int k = 0; k < 3; ++k) row.vertex[k] = vertex.data()[static_cast<std::size_t>(y - 1 + k) * w].data();
    n[0] = n[w - 1] = zero;
    kernels::normal_row(row, 1, w - 1, n->data());
  }
}

}  // namespace ef::slam
