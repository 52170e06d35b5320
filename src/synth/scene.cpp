#include "synth/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "synth/det_math.h"

namespace ef::synth {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Distance of a point to a box (half extents h, centred at the origin) given as q = |p| - h:
// positive outside, negative inside.
float box_sdf(float qx, float qy, float qz) {
  const float ox = std::max(qx, 0.0f), oy = std::max(qy, 0.0f), oz = std::max(qz, 0.0f);
  const float outside = std::sqrt(ox * ox + oy * oy + oz * oz);
  const float inside = std::min(std::max(qx, std::max(qy, qz)), 0.0f);
  return outside + inside;
}

float rect_sdf(float qx, float qy) {
  const float ox = std::max(qx, 0.0f), oy = std::max(qy, 0.0f);
  return std::sqrt(ox * ox + oy * oy) + std::min(std::max(qx, qy), 0.0f);
}

// Interval [t0, t1] where o + t d lies within |x| <= h along one axis; false when never.
// Dot product summed left to right in scalar code (Eigen's reductions may use other orders and
// fused multiply-adds on ARM64's NEON half packets).
float dot3(const Eigen::Vector3f& a, const Eigen::Vector3f& b) { return a.x() * b.x() + a.y() * b.y() + a.z() * b.z(); }

bool slab(float o, float d, float h, float& t0, float& t1) {
  if (d == 0.0f) {
    t0 = -kInf;
    t1 = kInf;
    return std::fabs(o) <= h;
  }
  const float inv = 1.0f / d;
  const float a = (-h - o) * inv, b = (h - o) * inv;
  t0 = std::min(a, b);
  t1 = std::max(a, b);
  return true;
}

}  // namespace

Eigen::Vector3f Primitive::to_local(const Eigen::Vector3f& p) const {
  const float dx = p.x() - center.x(), dy = p.y() - center.y();
  return Eigen::Vector3f(cos_yaw * dx + sin_yaw * dy, -sin_yaw * dx + cos_yaw * dy, p.z() - center.z());
}

Eigen::Vector3f Primitive::dir_to_world(const Eigen::Vector3f& d) const {
  return Eigen::Vector3f(cos_yaw * d.x() - sin_yaw * d.y(), sin_yaw * d.x() + cos_yaw * d.y(), d.z());
}

float Primitive::local_signed_distance(const Eigen::Vector3f& q) const {
  switch (shape) {
    case Shape::kBox:
      return box_sdf(std::fabs(q.x()) - half.x(), std::fabs(q.y()) - half.y(), std::fabs(q.z()) - half.z());
    case Shape::kCylinder:
      return rect_sdf(std::sqrt(q.x() * q.x() + q.y() * q.y()) - half.x(), std::fabs(q.z()) - half.z());
    case Shape::kSphere:
      return std::sqrt(dot3(q, q)) - half.x();
  }
  return kInf;
}

bool intersect_local(const Primitive& p, const Eigen::Vector3f& o, const Eigen::Vector3f& d, float t_min,
                     float& t, Eigen::Vector3f& n_local) {
  if (p.shape == Shape::kBox) {
    float tn = -kInf, tf = kInf;
    int axis_n = 0, axis_f = 0;
    for (int i = 0; i < 3; ++i) {
      float a, b;
      if (!slab(o[i], d[i], p.half[i], a, b)) return false;
      if (a > tn) { tn = a; axis_n = i; }
      if (b < tf) { tf = b; axis_f = i; }
    }
    if (tn > tf || tf <= t_min) return false;
    // From outside the entry face; from inside (a camera should never be there) the exit face.
    const bool entering = tn > t_min;
    const int axis = entering ? axis_n : axis_f;
    t = entering ? tn : tf;
    n_local = Eigen::Vector3f::Zero();
    n_local[axis] = d[axis] > 0 ? -1.0f : 1.0f;
    return true;
  }
  if (p.shape == Shape::kCylinder) {
    const float r = p.half.x();
    float tz0, tz1;
    if (!slab(o.z(), d.z(), p.half.z(), tz0, tz1)) return false;
    const float a = d.x() * d.x() + d.y() * d.y();
    const float b = o.x() * d.x() + o.y() * d.y();  // half of the usual b
    const float c = o.x() * o.x() + o.y() * o.y() - r * r;
    float ts0, ts1;
    if (a == 0.0f) {
      if (c > 0) return false;
      ts0 = -kInf;
      ts1 = kInf;
    } else {
      const float disc = b * b - a * c;
      if (disc < 0) return false;
      const float s = std::sqrt(disc);
      ts0 = (-b - s) / a;
      ts1 = (-b + s) / a;
    }
    const float tn = std::max(ts0, tz0), tf = std::min(ts1, tz1);
    if (tn > tf || tf <= t_min) return false;
    const bool entering = tn > t_min;
    t = entering ? tn : tf;
    const bool side = entering ? ts0 > tz0 : ts1 < tz1;
    if (side) {
      const float px = o.x() + t * d.x(), py = o.y() + t * d.y();
      const float inv_r = 1.0f / r;
      n_local = Eigen::Vector3f(px * inv_r, py * inv_r, 0.0f) * (entering ? 1.0f : -1.0f);
    } else {
      n_local = Eigen::Vector3f(0, 0, d.z() > 0 ? -1.0f : 1.0f);
    }
    return true;
  }
  // Sphere.
  const float r = p.half.x();
  const float a = dot3(d, d);
  const float b = dot3(o, d);
  const float c = dot3(o, o) - r * r;
  const float disc = b * b - a * c;
  if (disc < 0) return false;
  const float s = std::sqrt(disc);
  const float t0 = (-b - s) / a, t1 = (-b + s) / a;
  if (t1 <= t_min) return false;
  const bool entering = t0 > t_min;
  t = entering ? t0 : t1;
  n_local = (o + t * d) * ((entering ? 1.0f : -1.0f) / r);
  return true;
}

int Scene::add(Primitive p) {
  det_sincosf(p.yaw, p.sin_yaw, p.cos_yaw);
  primitives.push_back(p);
  return static_cast<int>(primitives.size()) - 1;
}

float Scene::free_space_distance(const Eigen::Vector3f& p) const {
  float d = std::min({p.x(), size.x() - p.x(), p.y(), size.y() - p.y(), p.z(), size.z() - p.z()});
  for (const Primitive& prim : primitives) d = std::min(d, prim.local_signed_distance(prim.to_local(p)));
  return d;
}

float Scene::distance_to_surface(const Eigen::Vector3f& p) const {
  float d = std::min({std::fabs(p.x()), std::fabs(size.x() - p.x()), std::fabs(p.y()), std::fabs(size.y() - p.y()),
                      std::fabs(p.z()), std::fabs(size.z() - p.z())});
  for (const Primitive& prim : primitives) d = std::min(d, std::fabs(prim.local_signed_distance(prim.to_local(p))));
  return d;
}

float Scene::floor_clearance(const Eigen::Vector3f& p, float z_max) const {
  float d = std::min({p.x(), size.x() - p.x(), p.y(), size.y() - p.y()});
  for (const Primitive& prim : primitives) {
    if (prim.center.z() - prim.half.z() >= z_max) continue;  // overhead: a robot passes below
    if (prim.center.z() + prim.half.z() < 0.03f) continue;    // flat on the floor (rugs): drives over
    const Eigen::Vector3f q = prim.to_local(p);
    const float dist = prim.shape == Shape::kBox
                           ? rect_sdf(std::fabs(q.x()) - prim.half.x(), std::fabs(q.y()) - prim.half.y())
                           : std::sqrt(q.x() * q.x() + q.y() * q.y()) - prim.half.x();
    d = std::min(d, dist);
  }
  return d;
}

bool Scene::raycast(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, Hit& hit, float t_min) const {
  bool found = false;
  hit.t = kInf;
  // Room box, seen from inside: the nearest exit through a face.
  for (int axis = 0; axis < 3; ++axis) {
    if (dir[axis] == 0.0f) continue;
    const bool positive = dir[axis] > 0;
    const float t = ((positive ? size[axis] : 0.0f) - origin[axis]) / dir[axis];
    if (t > t_min && t < hit.t) {
      static constexpr int kFace[3][2] = {{kWallXMin, kWallXMax}, {kWallYMin, kWallYMax}, {kFloorFace, kCeilingFace}};
      hit.t = t;
      hit.normal = Eigen::Vector3f::Zero();
      hit.normal[axis] = positive ? -1.0f : 1.0f;
      hit.surface = -1 - kFace[axis][positive ? 1 : 0];
      hit.label = axis == 2 ? (positive ? kCeiling : kFloor) : kWall;
      found = true;
    }
  }
  for (std::size_t i = 0; i < primitives.size(); ++i) {
    const Primitive& p = primitives[i];
    const Eigen::Vector3f o = p.to_local(origin);
    const Eigen::Vector3f d(p.cos_yaw * dir.x() + p.sin_yaw * dir.y(), -p.sin_yaw * dir.x() + p.cos_yaw * dir.y(), dir.z());
    float t;
    Eigen::Vector3f n;
    if (intersect_local(p, o, d, t_min, t, n) && t < hit.t) {
      hit.t = t;
      hit.normal = p.dir_to_world(n);
      hit.label = p.label;
      hit.surface = static_cast<int>(i);
      found = true;
    }
  }
  return found;
}

std::vector<bool> Scene::classes_present() const {
  std::vector<bool> present(kNumClassesWithUnknown, false);
  present[kFloor] = present[kCeiling] = present[kWall] = true;
  for (const Primitive& p : primitives) present[p.label] = true;
  return present;
}

}  // namespace ef::synth
