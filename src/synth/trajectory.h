// Camera trajectories through a synthetic room: a hand-held loop and a planar robot path.
#pragma once

#include <cstdint>
#include <vector>

#include "core/result.h"
#include "core/se3.h"
#include "synth/scene.h"

namespace ef::synth {

enum class TrajectoryKind {
  kLoop,   // hand-held: a smooth loop around the room's middle at 1.2-1.6 m, looking across the room
           // with gentle height, pitch and roll wobble; long sequences go round again on a
           // different line of sight (loop closures)
  kRobot,  // planar: camera 0.3-0.6 m above the floor, level, on a smooth closed path that keeps
           // 0.3 m from every floor-standing object, looking ahead and slightly inwards
  kInspect,  // hand-held, inspecting: the loop's path, but the gaze turns (through the walking
             // direction) from the middle to the near wall and its furniture, 34 degrees down, and
             // back, about 2.4 times a lap: every place is seen across the room and from ~1.3 m
             // (the paper's office scan, "loopy both locally and globally")
};

// The hand-held kinds (kLoop, kInspect) share one path through the room; kRobot has its own.
constexpr bool is_handheld(TrajectoryKind kind) { return kind != TrajectoryKind::kRobot; }

struct TrajectoryOptions {
  TrajectoryKind kind = TrajectoryKind::kLoop;
  int frames = 300;        // poses to generate
  double fps = 30;         // frames per second (poses are i / fps seconds apart)
  uint32_t seed = 0;       // varies the path's shape, height and wobble
};

// Limits the trajectories respect (checked by the tests), per second.
constexpr double kMaxHandheldSpeed = 0.8;   // m/s  (2.7 cm per frame at 30 Hz)
constexpr double kMaxHandheldTurn = 1.0;    // rad/s (1.9 degrees per frame at 30 Hz)
constexpr double kRobotSpeed = 0.3;         // m/s
constexpr double kRobotTurn = 0.6;          // rad/s

// Camera-to-world poses T_wc (camera x right, y down, z forward) for frames 0 .. frames-1.
// Fails when no collision-free path fits in the room.
Result<std::vector<SE3>> make_trajectory(const Scene& scene, const TrajectoryOptions& options);

// The hand-held loop's height swings by up to this much (metres: its two height waves, 0.1 and
// 0.04 m) around its base height, in a different way on every lap.
constexpr double kHandheldHeightSwing = 0.14;

// One lap of the path that make_trajectory samples for `options` (its kind and seed; the frame
// count does not matter): camera positions (world metres) every half degree of the path's
// parameter, with z the path's base height (see kHandheldHeightSwing). Furniture added to the
// room afterwards (RoomLayout::kIsland) keeps clear of it, so the trajectory stays the one of the
// room without it. Fails as make_trajectory does.
Result<std::vector<Eigen::Vector3f>> trajectory_lap(const Scene& scene, const TrajectoryOptions& options);

}  // namespace ef::synth
