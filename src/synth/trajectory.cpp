#include "synth/trajectory.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include "synth/det_math.h"
#include "synth/rng.h"

namespace ef::synth {

namespace {

using Vec3 = Eigen::Vector3d;
constexpr double kTwoPi = 6.283185307179586;

// Trigonometry comes from det_math.h, never libm: the poses must have the same bits on every
// machine (libm's last bit differs between glibc on x86-64 and on ARM64, and the sampler's
// decisions below would amplify one bit into a different frame).

// Quaternion of a rotation matrix, written out here rather than taken from Eigen so that its
// operations are compiled with this file's flags (no fused multiply-add) on every ISA. The same
// steps, in the same order, as Eigen 3.4's conversion (which the generator used before), so the
// poses keep their bits; SE3 normalises the result.
Eigen::Quaterniond to_quaternion(const Eigen::Matrix3d& m) {
  double q[4];  // x, y, z, w
  double t = (m(0, 0) + m(1, 1)) + m(2, 2);
  if (t > 0.0) {
    t = std::sqrt(t + 1.0);
    q[3] = 0.5 * t;
    t = 0.5 / t;
    q[0] = (m(2, 1) - m(1, 2)) * t;
    q[1] = (m(0, 2) - m(2, 0)) * t;
    q[2] = (m(1, 0) - m(0, 1)) * t;
  } else {
    int i = 0;
    if (m(1, 1) > m(0, 0)) i = 1;
    if (m(2, 2) > m(i, i)) i = 2;
    const int j = (i + 1) % 3, k = (j + 1) % 3;
    t = std::sqrt(((m(i, i) - m(j, j)) - m(k, k)) + 1.0);
    q[i] = 0.5 * t;
    t = 0.5 / t;
    q[3] = (m(k, j) - m(j, k)) * t;
    q[j] = (m(j, i) + m(i, j)) * t;
    q[k] = (m(k, i) + m(i, k)) * t;
  }
  return Eigen::Quaterniond(q[3], q[0], q[1], q[2]);
}

SE3 make_pose(const Eigen::Matrix3d& R, const Vec3& t) { return SE3(to_quaternion(R), t); }

// Rotation angle of a unit quaternion, radians in [0, pi] (as SE3::angle, with det_atan2).
double rotation_angle(const Eigen::Quaterniond& q) {
  const double v = std::sqrt((q.x() * q.x() + q.y() * q.y()) + q.z() * q.z());
  return 2.0 * det_atan2(v, std::fabs(q.w()));
}

// Camera rotation looking along `forward` with world z up, then rolled by `roll` radians about
// the optical axis. Columns: camera x (right), y (down), z (forward) in world coordinates.
Eigen::Matrix3d look_along(Vec3 forward, double roll) {
  forward.normalize();
  Vec3 right = forward.cross(Vec3::UnitZ()).normalized();
  Vec3 down = forward.cross(right);
  double s, c;
  det_sincos(roll, s, c);
  const Vec3 r2 = c * right + s * down, d2 = -s * right + c * down;
  Eigen::Matrix3d R;
  R.col(0) = r2;
  R.col(1) = d2;
  R.col(2) = forward;
  return R;
}

// Smooth periodic path parameters, all drawn from the seed.
struct Wobble {
  double phase[10];
  explicit Wobble(uint32_t seed) {
    Pcg32 rng(seed, 0x14057b7ef767814fULL);
    for (double& p : phase) p = kTwoPi * rng.uniform();
  }
};

// Pose as a function of the path parameter s (radians around the loop).
using PathFn = std::function<SE3(double)>;

// Samples `frames` poses at 1/fps s intervals, advancing s so that neither the speed nor the
// turn rate exceeds its limit (whichever binds sets the pace).
std::vector<SE3> sample(const PathFn& path, int frames, double fps, double v_max, double w_max) {
  std::vector<SE3> out;
  out.reserve(static_cast<std::size_t>(frames));
  const double ds = kTwoPi / 20000.0;  // fine step of the path parameter
  double s = 0, t = 0;
  SE3 prev = path(0);
  out.push_back(prev);
  for (int i = 1; i < frames; ++i) {
    const double target = static_cast<double>(i) / fps;
    while (true) {
      const SE3 next = path(s + ds);
      const Vec3 step = next.translation() - prev.translation();
      const double dp = std::sqrt((step.x() * step.x() + step.y() * step.y()) + step.z() * step.z());
      const double da = rotation_angle(prev.inverse().rotation() * next.rotation());
      const double dt = std::max(dp / v_max, da / w_max);
      if (t + dt >= target) {
        // Interpolate within this fine step (linear in s is fine at this resolution).
        const double f = dt > 0 ? (target - t) / dt : 0;
        const double s_frame = s + f * ds;
        out.push_back(path(s_frame));
        break;
      }
      t += dt;
      s += ds;
      prev = next;
    }
  }
  return out;
}

// A path and the limits its sampling keeps to.
struct Path {
  PathFn pose;
  double speed = 0;        // m/s
  double turn = 0;         // rad/s
  double base_height = 0;  // metres: the height the hand-held loop swings around (robot: its height)
};

// Gaze of the inspecting scan (TrajectoryKind::kInspect) at position `p`, given the loop's gaze
// point `target` in the middle and the swing g in [0, 1]: g = 0 looks at the target as the loop
// does, g = 1 turns half round (through `side`, +1 or -1) to the wall behind, kInspectPitch below
// the horizon. Yaw and pitch are blended, not the two points, so the gaze never passes the vertical.
constexpr double kInspectPitch = -0.6;  // radians (34 degrees down): the near wall's furniture, about 1.3 m away
Vec3 inspect_gaze(const Vec3& p, const Vec3& target, double g, double side) {
  const Vec3 in = target - p;
  const double horizontal = std::sqrt(in.x() * in.x() + in.y() * in.y());
  const double yaw = det_atan2(in.y(), in.x()) + side * (kTwoPi / 2) * g;
  const double pitch = (1 - g) * det_atan2(in.z(), horizontal) + g * kInspectPitch;
  double sy, cy, sp, cp;
  det_sincos(yaw, sy, cy);
  det_sincos(pitch, sp, cp);
  return Vec3(cp * cy, cp * sy, sp);
}

Result<Path> handheld_loop(const Scene& scene, const TrajectoryOptions& o) {
  const bool inspect = o.kind == TrajectoryKind::kInspect;
  const Wobble w(o.seed);
  Pcg32 rng(o.seed, 0x3c6ef372fe94f82aULL);
  const double W = scene.size.x(), D = scene.size.y(), H = scene.size.z();
  const Vec3 centre(W / 2, D / 2, 0);
  const double height = std::min(H - 0.5, static_cast<double>(rng.uniform(1.25f, 1.5f)));
  double a = std::max(0.6, W / 2 - 1.1), b = std::max(0.6, D / 2 - 1.1);
  const double clockwise = rng.chance(0.5f) ? -1.0 : 1.0;
  for (int attempt = 0; attempt < 12; ++attempt, a *= 0.9, b *= 0.9) {
    const PathFn path = [=](double s) {
      const double u = clockwise * s;
      const Vec3 p(centre.x() + a * (1 + 0.08 * det_sin(2 * u + w.phase[0])) * det_cos(u),
                   centre.y() + b * (1 + 0.08 * det_sin(3 * u + w.phase[1])) * det_sin(u),
                   height + 0.1 * det_sin(1.7 * u + w.phase[2]) + 0.04 * det_sin(4.3 * u + w.phase[3]));
      // The gaze point drifts around the middle at a frequency incommensurate with the loop, so a
      // second lap sees the same places from other directions.
      const Vec3 target(centre.x() + 0.45 * W / 5 * det_cos(0.63 * u + w.phase[4]),
                        centre.y() + 0.45 * D / 5 * det_sin(0.71 * u + w.phase[5]),
                        1.0 + 0.35 * det_sin(1.3 * u + w.phase[6]));
      const double roll = 0.05 * det_sin(1.1 * u + w.phase[7]) + 0.02 * det_sin(2.9 * u + w.phase[8]);
      if (!inspect) return make_pose(look_along(target - p, roll), p);
      // The scan turns from the middle to the near wall and back about 2.4 times a lap (a
      // frequency incommensurate with the loop, so the next lap turns at other places), with a
      // dwell at each end (sin of sin: flat there, smooth everywhere, so the pace changes
      // gently): each place is seen across the room and from close by.
      const double g = 0.5 - 0.5 * det_sin(kTwoPi / 4 * det_sin(2.37 * u + w.phase[9]));
      return make_pose(look_along(inspect_gaze(p, target, g, -clockwise), roll), p);
    };
    // Height wobble is not periodic in s (later laps differ), so check the whole band of heights
    // it can reach (+-kHandheldHeightSwing) at every sample of one lap.
    bool clear = true;
    for (int k = 0; k < 720 && clear; ++k) {
      Eigen::Vector3f p = path(kTwoPi * k / 720.0).translation().cast<float>();
      for (int j = -2; j <= 2 && clear; ++j) {
        p.z() = static_cast<float>(height + kHandheldHeightSwing / 2 * j);
        clear = scene.free_space_distance(p) > 0.33f;
      }
    }
    if (!clear) continue;
    // Pace: one lap over the sequence when that is a realistic hand-held speed, else 0.3 m/s.
    const double perimeter = 3.3 * (a + b);
    const double seconds = o.frames / o.fps;
    const double v = std::clamp(perimeter / std::max(seconds, 1e-3), 0.3, kMaxHandheldSpeed);
    return Path{path, v, kMaxHandheldTurn, height};
  }
  return error(ErrorCode::kInternal, "synthetic: no collision-free hand-held loop fits in room '" + scene.name + "'");
}

Result<Path> robot_path(const Scene& scene, const TrajectoryOptions& o) {
  const Wobble w(o.seed ^ 0x9e3779b9U);
  Pcg32 rng(o.seed, 0x7f4a7c159e3779b9ULL);
  const double W = scene.size.x(), D = scene.size.y();
  const double height = rng.uniform(0.3f, 0.6f);
  const double clockwise = rng.chance(0.5f) ? -1.0 : 1.0;
  constexpr float kRobotRadius = 0.3f;  // metres of clearance to walls and furniture footprints
  constexpr float kRobotTop = 0.9f;     // metres: objects entirely above this do not block it
  // Largest ellipse (shrinking, shifting the centre) that keeps the clearance.
  for (double scale = 1.0; scale > 0.1; scale -= 0.05) {
    for (int shift = 0; shift < 25; ++shift) {
      const Vec3 centre(W / 2 + 0.3 * ((shift % 5) - 2), D / 2 + 0.3 * ((shift / 5) - 2), 0);
      const double a = scale * (W / 2 - 0.5), b = scale * (D / 2 - 0.5);
      const auto position = [=](double u) {
        return Vec3(centre.x() + a * (1 + 0.1 * det_sin(2 * u + w.phase[0])) * det_cos(u),
                    centre.y() + b * (1 + 0.1 * det_sin(3 * u + w.phase[1])) * det_sin(u), height);
      };
      bool clear = true;
      for (int k = 0; k < 720 && clear; ++k)
        clear = scene.floor_clearance(position(kTwoPi * k / 720.0).cast<float>(), kRobotTop) > kRobotRadius;
      if (!clear) continue;
      const PathFn path = [=](double s) {
        const double u = clockwise * s;
        const Vec3 p = position(u);
        const Vec3 tangent = (position(u + 1e-4) - position(u - 1e-4)) * clockwise;
        // Look ahead and turned towards the inside of the loop, swaying gently.
        const double heading = det_atan2(tangent.y(), tangent.x()) + clockwise * 0.45 + 0.25 * det_sin(0.8 * u + w.phase[2]);
        double sh, ch;
        det_sincos(heading, sh, ch);
        return make_pose(look_along(Vec3(ch, sh, 0), 0.0), p);
      };
      return Path{path, kRobotSpeed, kRobotTurn, height};
    }
  }
  return error(ErrorCode::kInternal, "synthetic: no collision-free robot path fits in room '" + scene.name + "'");
}

// The path of `options`' kind and seed through the room.
Result<Path> make_path(const Scene& scene, const TrajectoryOptions& options) {
  return is_handheld(options.kind) ? handheld_loop(scene, options) : robot_path(scene, options);
}

}  // namespace

Result<std::vector<SE3>> make_trajectory(const Scene& scene, const TrajectoryOptions& options) {
  if (options.frames <= 0) return error(ErrorCode::kInvalidArgument, "synthetic: frames must be positive");
  EF_ASSIGN_OR_RETURN(const Path path, make_path(scene, options));
  return sample(path.pose, options.frames, options.fps, path.speed, path.turn);
}

Result<std::vector<Eigen::Vector3f>> trajectory_lap(const Scene& scene, const TrajectoryOptions& options) {
  EF_ASSIGN_OR_RETURN(const Path path, make_path(scene, options));
  constexpr int kSamples = 720;  // every half degree of the path parameter
  std::vector<Eigen::Vector3f> lap;
  lap.reserve(kSamples);
  for (int k = 0; k < kSamples; ++k) {
    Eigen::Vector3f p = path.pose(kTwoPi * k / kSamples).translation().cast<float>();
    p.z() = static_cast<float>(path.base_height);
    lap.push_back(p);
  }
  return lap;
}

}  // namespace ef::synth
