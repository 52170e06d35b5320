// The built-in rooms and the random room generator.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/result.h"
#include "synth/scene.h"

namespace ef::synth {

// Names of the built-in rooms, the default ("living_room") first. Together they contain all 13
// classes.
const std::vector<std::string>& builtin_room_names();

// Builds a room. `name`: a built-in room (fixed layout: `seed` is ignored), "" for the default
// room, or "random" for a room of a random kind, size and layout drawn from `seed`. An unknown
// name is an error that lists the known ones.
Result<Scene> build_room(const std::string& name, uint32_t seed);

}  // namespace ef::synth
