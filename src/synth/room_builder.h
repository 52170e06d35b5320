// The built-in rooms and the random room generator.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/result.h"
#include "synth/scene.h"
#include "synth/trajectory.h"

namespace ef::synth {

// Names of the built-in rooms, the default ("living_room") first. Together they contain all 13
// classes.
const std::vector<std::string>& builtin_room_names();

// Where a room's furniture stands.
enum class RoomLayout {
  kWalls,   // along the walls only; the middle stays free (the default)
  kIsland,  // also one group in the middle (a dining table with chairs, a free-standing sofa, a
            // kitchen counter, shelves back to back, or where none of those fits a low table with
            // things on it), which the camera's path circles and the hand-held loop looks across,
            // so that it hides a different part of the room in every view. The rest of the room
            // is the same as with kWalls.
};

// Builds a room. `name`: a built-in room (fixed layout: `seed` is ignored), "" for the default
// room, or "random" for a room of a random kind, size and layout drawn from `seed`. An unknown
// name is an error that lists the known ones.
// With RoomLayout::kIsland the middle group keeps clear of one lap of the trajectory of kind
// `path` and seed `seed` through the room without it (trajectory_lap), so make_trajectory gives
// the same poses in both layouts; an error when no group fits.
Result<Scene> build_room(const std::string& name, uint32_t seed, RoomLayout layout = RoomLayout::kWalls,
                         TrajectoryKind path = TrajectoryKind::kLoop);

}  // namespace ef::synth
