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
