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
  // Semantics (SemanticFusion): the CNN every N-th frame, Bayesian label fusion into the surfels,
  // an optional dense CRF, rendered label images.
  bool labels = true;                   // segment and fuse labels; false = geometry only
  std::string model;                    // .efm segmentation model; empty = the shipped model
  int label_every = 10;                 // CNN + Bayesian update every N frames (>= 1; paper: 10)
  std::string labels_out;               // folder for rendered class-id PNGs; empty = none
  int labels_out_every = 10;            // write the rendering of every K-th frame (>= 1)
  int crf_every = 0;                    // dense CRF over the map every M frames; 0 = off (paper: 500)
  bool crf_final = false;               // one dense CRF over the map at the end of the run
  int crf_iterations = 10;              // mean-field iterations per CRF run (1..100; paper: 10)
  bool label_visibility = true;         // fuse / render only surfels whose depth matches the measured
                                        // depth (semantic/visibility.h); false = every index-map surfel

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
