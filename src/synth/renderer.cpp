#include "synth/renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "synth/materials.h"

namespace ef::synth {

namespace {

constexpr float kNear = 0.02f;  // metres: closer geometry is not seen (and not binned)
constexpr float kTMin = 1e-4f;

// Texture coordinates (metres, from the face centre) and the face's half size for a hit on a
// primitive at local point q with local normal n.
void primitive_uv(const Primitive& p, const Eigen::Vector3f& q, const Eigen::Vector3f& n, float& u, float& v, float& hu,
                  float& hv) {
  if (p.shape == Shape::kBox) {
    if (n.z() != 0.0f) {
      u = q.x(); v = q.y(); hu = p.half.x(); hv = p.half.y();
    } else if (n.y() != 0.0f) {
      u = n.y() > 0 ? q.x() : -q.x(); v = q.z(); hu = p.half.x(); hv = p.half.z();
    } else {
      u = n.x() > 0 ? -q.y() : q.y(); v = q.z(); hu = p.half.y(); hv = p.half.z();
    }
    return;
  }
  // Curved shapes: an unwrapping that needs no trigonometry and is continuous enough for noise.
  if (p.shape == Shape::kCylinder && std::fabs(n.z()) > 0.5f) {
    u = q.x(); v = q.y();
  } else {
    u = q.x() - q.y(); v = q.z();
  }
  hu = hv = 0.0f;
}

inline uint8_t to_srgb8(float linear) { return static_cast<uint8_t>(linear_to_levels(linear) + 0.5f); }

// Tile index range [lo, hi] as integers. The float bounds can be far outside the image (up to
// +-1e9 for primitives crossing the near plane): clamp before converting, since a float to int16
// conversion out of range is undefined (x86-64 wraps, ARM64 saturates). An empty range (lo > hi)
// culls the primitive.
inline int16_t tile_bound(float t, int tiles) {
  return static_cast<int16_t>(std::min(std::max(t, -1.0f), static_cast<float>(tiles)));
}

// Matrix products and dot products written out in scalar code, summed left to right. Eigen's own
// products and reductions are not used here: on ARM64 Eigen evaluates 3 x 3 float products with NEON half-packet fused
// multiply-adds (vfma, whatever -ffp-contract says) and on x86-64 with separate multiplies and
// adds, so the images would differ in the last bits of depth (and then in colour).
inline Eigen::Vector3f mul(const Eigen::Matrix3f& M, const Eigen::Vector3f& v) {
  return Eigen::Vector3f(M(0, 0) * v.x() + M(0, 1) * v.y() + M(0, 2) * v.z(),
                         M(1, 0) * v.x() + M(1, 1) * v.y() + M(1, 2) * v.z(),
                         M(2, 0) * v.x() + M(2, 1) * v.y() + M(2, 2) * v.z());
}
inline float dot(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  return a.x() * b.x() + a.y() * b.y() + a.z() * b.z();
}
// A * B^T.
inline Eigen::Matrix3f mul_transposed(const Eigen::Matrix3f& A, const Eigen::Matrix3f& B) {
  Eigen::Matrix3f C;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) C(i, j) = A(i, 0) * B(j, 0) + A(i, 1) * B(j, 1) + A(i, 2) * B(j, 2);
  return C;
}

// Rotation matrix of the unit quaternion q, written out here (not Eigen's toRotationMatrix) so that
// its operations are compiled with this file's flags (no fused multiply-add) on every ISA.
Eigen::Matrix3f rotation_of(const Eigen::Quaterniond& q) {
  const double x = q.x(), y = q.y(), z = q.z(), w = q.w();
  const double tx = 2 * x, ty = 2 * y, tz = 2 * z;
  const double twx = tx * w, twy = ty * w, twz = tz * w;
  const double txx = tx * x, txy = ty * x, txz = tz * x;
  const double tyy = ty * y, tyz = tz * y, tzz = tz * z;
  Eigen::Matrix3d R;
  R << 1 - (tyy + tzz), txy - twz, txz + twy,
       txy + twz, 1 - (txx + tzz), tyz - twx,
       txz - twy, tyz + twx, 1 - (txx + tyy);
  return R.cast<float>();
}

}  // namespace

float linear_to_levels(float linear) {
  // NaN -> 0: converting NaN to an integer is undefined, and x86-64 and ARM64 give different values.
  const float c = linear > 0.0f ? std::min(linear, 1.0f) : 0.0f;
  return std::sqrt(c) * 255.0f;
}

float levels_to_linear(uint8_t levels) {
  const float c = static_cast<float>(levels) * (1.0f / 255.0f);
  return c * c;
}

Renderer::Renderer(const Scene& scene, const Intrinsics& intrinsics) : scene_(scene), K_(intrinsics) {
  tiles_x_ = (K_.width + kTile - 1) / kTile;
  tiles_y_ = (K_.height + kTile - 1) / kTile;
  const std::size_t n = scene_.primitives.size();
  frame_prims_.resize(n);
  order_.resize(n);
  rect_.resize(4 * n);
  tile_lists_.resize(static_cast<std::size_t>(tiles_x_) * tiles_y_ * std::max<std::size_t>(n, 1));
  tile_counts_.resize(static_cast<std::size_t>(tiles_x_) * tiles_y_);
  incidence_.allocate(K_.width, K_.height);
}

void Renderer::bin_primitives(const Eigen::Matrix3f& R_cw, const Eigen::Vector3f& t_wc) {
  const std::size_t n = scene_.primitives.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Primitive& p = scene_.primitives[i];
    FramePrim& fp = frame_prims_[i];
    // Camera direction -> world (R_wc = R_cw^T) -> local (rotation by -yaw about z).
    Eigen::Matrix3f R_lw;
    R_lw << p.cos_yaw, p.sin_yaw, 0, -p.sin_yaw, p.cos_yaw, 0, 0, 0, 1;
    fp.M = mul_transposed(R_lw, R_cw);
    fp.origin = p.to_local(t_wc);
    // Project the 8 corners of the local bounding box.
    float z_min = std::numeric_limits<float>::infinity();
    float u0 = std::numeric_limits<float>::infinity(), v0 = u0, u1 = -u0, v1 = -u0;
    bool crosses_near = false, all_behind = true;
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3f corner_local((c & 1 ? 1.f : -1.f) * p.half.x(), (c & 2 ? 1.f : -1.f) * p.half.y(),
                                         (c & 4 ? 1.f : -1.f) * p.half.z());
      const Eigen::Vector3f pw = p.center + p.dir_to_world(corner_local);
      const Eigen::Vector3f pc = mul(R_cw, pw - t_wc);
      z_min = std::min(z_min, pc.z());
      if (pc.z() < kNear) {
        crosses_near = true;
        continue;
      }
      all_behind = false;
      const float iz = 1.0f / pc.z();
      const float u = K_.fx * pc.x() * iz + K_.cx, v = K_.fy * pc.y() * iz + K_.cy;
      u0 = std::min(u0, u); u1 = std::max(u1, u);
      v0 = std::min(v0, v); v1 = std::max(v1, v);
    }
    fp.z_min = std::max(z_min, 0.0f);
    int16_t* r = &rect_[4 * i];
    if (all_behind) {
      r[0] = 1; r[2] = 0;  // culled
      continue;
    }
    if (crosses_near) {  // partly behind the camera: no safe projection, cover the whole image
      u0 = v0 = -1e9f;
      u1 = v1 = 1e9f;
    }
    const float tx0 = std::floor((u0 - 1.0f) / kTile), tx1 = std::floor((u1 + 1.0f) / kTile);
    const float ty0 = std::floor((v0 - 1.0f) / kTile), ty1 = std::floor((v1 + 1.0f) / kTile);
    r[0] = std::max<int16_t>(tile_bound(tx0, tiles_x_), 0);
    r[1] = std::max<int16_t>(tile_bound(ty0, tiles_y_), 0);
    r[2] = std::min<int16_t>(tile_bound(tx1, tiles_x_), static_cast<int16_t>(tiles_x_ - 1));
    r[3] = std::min<int16_t>(tile_bound(ty1, tiles_y_), static_cast<int16_t>(tiles_y_ - 1));
  }
  for (std::size_t i = 0; i < n; ++i) order_[i] = static_cast<uint16_t>(i);
  std::sort(order_.begin(), order_.end(), [this](uint16_t a, uint16_t b) {
    return frame_prims_[a].z_min < frame_prims_[b].z_min || (frame_prims_[a].z_min == frame_prims_[b].z_min && a < b);
  });
  std::fill(tile_counts_.begin(), tile_counts_.end(), 0);
  for (std::size_t k = 0; k < n; ++k) {
    const uint16_t i = order_[k];
    const int16_t* r = &rect_[4 * i];
    for (int ty = r[1]; ty <= r[3]; ++ty)
      for (int tx = r[0]; tx <= r[2]; ++tx) {
        const std::size_t tile = static_cast<std::size_t>(ty) * tiles_x_ + tx;
        tile_lists_[tile * n + tile_counts_[tile]++] = i;
      }
  }
}

Eigen::Vector3f Renderer::shade(const Material& m, float u, float v, float hu, float hv, const Eigen::Vector3f& p,
                                const Eigen::Vector3f& n) const {
  const Eigen::Vector3f a = albedo(m, u, v, hu, hv);
  Eigen::Vector3f light = scene_.ambient;
  for (const Light& l : scene_.lights) {
    const Eigen::Vector3f L = l.position - p;
    const float d2 = dot(L, L);
    const float ndl = dot(n, L) / std::sqrt(d2);
    if (ndl > 0) light += l.color * (ndl / (1.0f + d2 / (l.falloff * l.falloff)));
  }
  return a.cwiseProduct(light * (1.0f - m.emission) + Eigen::Vector3f::Constant(m.emission));
}

void Renderer::render(const SE3& T_wc, ImageView<Rgb8> color, ImageView<float> depth, ImageView<uint8_t> labels) {
  const Eigen::Matrix3f R_wc = rotation_of(T_wc.rotation());
  const Eigen::Vector3f t_wc = T_wc.translation().cast<float>();
  const Eigen::Matrix3f R_cw = R_wc.transpose();
  bin_primitives(R_cw, t_wc);
  const std::size_t n = scene_.primitives.size();
  const Eigen::Vector3f room = scene_.size;
  const float inv_fx = 1.0f / K_.fx, inv_fy = 1.0f / K_.fy;
  ImageView<float> incidence = incidence_.view();

  for (int ty = 0; ty < tiles_y_; ++ty) {
    for (int tx = 0; tx < tiles_x_; ++tx) {
      const std::size_t tile = static_cast<std::size_t>(ty) * tiles_x_ + tx;
      const uint16_t* list = tile_lists_.data() + tile * n;
      const int count = tile_counts_[tile];
      const int y_end = std::min(K_.height, (ty + 1) * kTile), x_end = std::min(K_.width, (tx + 1) * kTile);
      for (int y = ty * kTile; y < y_end; ++y) {
        const float yn = (static_cast<float>(y) - K_.cy) * inv_fy;
        for (int x = tx * kTile; x < x_end; ++x) {
          const float xn = (static_cast<float>(x) - K_.cx) * inv_fx;
          const Eigen::Vector3f dc(xn, yn, 1.0f);  // ray parameter t == depth along z
          const Eigen::Vector3f dw = mul(R_wc, dc);
          // The room box from inside: nearest face the ray leaves through.
          float best = std::numeric_limits<float>::infinity();
          int axis = 0;
          bool positive = false;
          for (int a = 0; a < 3; ++a) {
            if (dw[a] == 0.0f) continue;
            const bool pos = dw[a] > 0;
            const float t = ((pos ? room[a] : 0.0f) - t_wc[a]) / dw[a];
            if (t > kTMin && t < best) { best = t; axis = a; positive = pos; }
          }
          int hit_prim = -1;
          Eigen::Vector3f hit_n;
          for (int k = 0; k < count; ++k) {
            const uint16_t i = list[k];
            const FramePrim& fp = frame_prims_[i];
            if (fp.z_min >= best) break;  // this and all later ones lie behind the hit
            const Eigen::Vector3f dl = mul(fp.M, dc);
            float t;
            Eigen::Vector3f nl;
            if (intersect_local(scene_.primitives[i], fp.origin, dl, kTMin, t, nl) && t < best) {
              best = t;
              hit_prim = i;
              hit_n = nl;
            }
          }
          Eigen::Vector3f rgb;
          Eigen::Vector3f nw;
          const Eigen::Vector3f pw = t_wc + best * dw;
          uint8_t label;
          if (hit_prim >= 0) {
            const Primitive& p = scene_.primitives[hit_prim];
            const FramePrim& fp = frame_prims_[hit_prim];
            const Eigen::Vector3f q = fp.origin + best * mul(fp.M, dc);
            float u, v, hu, hv;
            primitive_uv(p, q, hit_n, u, v, hu, hv);
            nw = p.dir_to_world(hit_n);
            rgb = shade(p.material, u, v, hu, hv, pw, nw);
            label = p.label;
          } else {
            nw = Eigen::Vector3f::Zero();
            nw[axis] = positive ? -1.0f : 1.0f;
            int face;
            float u, v;
            if (axis == 2) {
              face = positive ? kCeilingFace : kFloorFace;
              u = pw.x(); v = pw.y();
              label = positive ? kCeiling : kFloor;
            } else {
              face = axis == 0 ? (positive ? kWallXMax : kWallXMin) : (positive ? kWallYMax : kWallYMin);
              u = axis == 0 ? pw.y() : pw.x();
              v = pw.z();
              label = kWall;
            }
            rgb = shade(scene_.face_material[face], u, v, 0.0f, 0.0f, pw, nw);
          }
          color(x, y) = Rgb8{to_srgb8(rgb.x()), to_srgb8(rgb.y()), to_srgb8(rgb.z())};
          depth(x, y) = best;
          labels(x, y) = label;
          incidence(x, y) = std::fabs(dot(nw, dw)) / std::sqrt(dot(dw, dw));
        }
      }
    }
  }
}

}  // namespace ef::synth
