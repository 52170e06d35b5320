// Options of `edgefusion run`, from defaults, then an optional configuration file, then the
// command line (each later one overrides the earlier).
//
// The configuration file is, for now, the flat subset of YAML: one `key: value` per line, '#'
// comments, no nesting. Issue 7 replaces the reader with yaml-cpp and nested sections; the keys
// below keep their names and units.
#pragma once

#include <cstdint>
#include <string>

#include "core/result.h"

namespace ef::app {

struct RunConfig {
  std::string source = "synthetic:";  // source URI (see `edgefusion --help`)
  int width = 320;                    // working resolution, pixels (tracking and label fusion)
  int height = 240;
  int64_t max_frames = -1;            // frames to process; -1 = all the source has
  std::string out_dir;                // output folder; required
  bool progress = true;               // progress line on stderr
  // Mapping (slam/surfel_slam.h). Defaults are ElasticFusion's / SemanticFusion's.
  int64_t surfel_capacity = 1'000'000;  // surfels in the pool, allocated at start-up
  double icp_weight = 10.0;             // tracking: relative weight of the ICP term (>= 0)
  double rgb_weight = 0.25;             // tracking: relative weight of the photometric term (>= 0)
  float depth_cutoff_m = 8.0f;          // depths beyond this are ignored, metres
  bool write_map = true;                // write map.ply at the end of the run

  // Multi-line "key: value  # unit, default" listing, as a configuration file would hold it.
  std::string describe() const;
};

// Applies the keys of a configuration file to `config`. Errors name the file, the line, the key
// and the bad value; unknown keys are errors.
Status apply_config_file(const std::string& path, RunConfig& config);

// Applies one key (as in the file) to `config`; errors name `where`, the key and the value.
Status apply_config_value(const std::string& key, const std::string& value, const std::string& where,
                          RunConfig& config);

}  // namespace ef::app
