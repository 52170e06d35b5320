// CPU ray caster for a Scene: colour, depth and labels of a pinhole camera, without sensor noise.
//
// Acceleration: per frame, every primitive's bounding box is projected into the image and binned
// into 16 x 16-pixel tiles; each tile's list is ordered by the primitive's nearest depth, so a
// pixel stops testing once the remaining primitives all lie behind its current hit.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/se3.h"
#include "synth/scene.h"

namespace ef::synth {

// The synthetic images' colour encoding, written once for the renderer and the colour camera
// (camera_model.h), which must undo it exactly: gamma 2 (a square root) instead of the exact sRGB
// curve, because a square root is exactly rounded on every machine. Out of line (renderer.cpp,
// compiled without fused multiply-add), so that no caller's arithmetic is contracted into it.
//   linear_to_levels: linear light, clamped to [0, 1] (NaN -> 0), to 8-bit levels 0..255, unrounded
//   levels_to_linear: 8-bit levels to linear light in [0, 1]
float linear_to_levels(float linear);
float levels_to_linear(uint8_t levels);

class Renderer {
 public:
  // Keeps a reference to `scene` (which must outlive the renderer) and allocates all scratch.
  Renderer(const Scene& scene, const Intrinsics& intrinsics);

  const Intrinsics& intrinsics() const { return K_; }

  // Renders the view from camera pose T_wc into images of the intrinsics' size: colour (sRGB),
  // depth (metres along the optical axis; every pixel hits something inside the room) and class
  // labels. Does not allocate.
  void render(const SE3& T_wc, ImageView<Rgb8> color, ImageView<float> depth, ImageView<uint8_t> labels);

  // |cos| of the angle between each pixel's ray and the surface normal it hit, [0, 1], from the
  // last render (the noise model drops grazing pixels).
  ImageView<const float> incidence() const { return incidence_.view(); }

 private:
  struct FramePrim {
    Eigen::Matrix3f M;       // camera-frame ray direction -> primitive-frame direction
    Eigen::Vector3f origin;  // camera centre in the primitive's frame, metres
    float z_min = 0;         // nearest depth of its bounding box in this view, metres
  };

  void bin_primitives(const Eigen::Matrix3f& R_cw, const Eigen::Vector3f& t_wc);
  Eigen::Vector3f shade(const Material& m, float u, float v, float hu, float hv, const Eigen::Vector3f& p_world,
                        const Eigen::Vector3f& n_world) const;

  static constexpr int kTile = 16;  // pixels
  const Scene& scene_;
  Intrinsics K_;
  int tiles_x_ = 0, tiles_y_ = 0;
  std::vector<FramePrim> frame_prims_;  // per primitive, this frame
  std::vector<uint16_t> order_;         // primitives by z_min
  std::vector<uint16_t> tile_lists_;    // tiles_x * tiles_y lists of primitive indices, each n_prims long
  std::vector<uint16_t> tile_counts_;
  std::vector<int16_t> rect_;           // per primitive: tile rectangle x0, y0, x1, y1 (inclusive), x0 > x1 = culled
  Image<float> incidence_;
};

}  // namespace ef::synth
