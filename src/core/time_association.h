// Matching two streams by timestamp, as the TUM RGB-D tools do (associate.py): used to pair rgb
// with depth images and estimated with reference poses.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

namespace ef {

// One-to-one association of two increasing timestamp lists (seconds): pairs (index in a, index in b)
// with |a - b| < max_dt, chosen greedily by smallest difference (ties: lower index in a, then in b);
// returned sorted by index in a.
std::vector<std::pair<std::size_t, std::size_t>> associate_timestamps(const std::vector<double>& a,
                                                                      const std::vector<double>& b, double max_dt);

}  // namespace ef
