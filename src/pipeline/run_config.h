// Options of `edgefusion run` (and `edgefusion plan`), from defaults, then an optional YAML
// configuration file, then the command line (each later one overrides the earlier).
//
// The file is YAML (read with yaml-cpp). Options sit at the top level or in sections; every
// section key also has its older flat name, so both of these set the same option:
//
//   mapping: {surfel_capacity: 500000}        surfel_capacity: 500000
//   labels: {every: 5}                        label_every: 5
//
// RunConfig::describe() prints every option with its unit and default as a complete file that reads
// back to the same configuration (`edgefusion plan --help` shows it for the defaults).
//
// A URI such as `synthetic:` or `openni2:` ends in ':', which YAML reads as a nested key: the reader
// quotes such a plain value on a `key: value` line itself (inside `{ }`, write it in quotes).
//
// Errors name the file, the line, the key (as written: `crf_iterations`, or the section path
// `crf.iterations`) and the bad value. Unknown keys, a key given twice and YAML syntax errors are
// errors too.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/result.h"
#include "platform/devices/gpio.h"

namespace ef::pipeline {

struct RunConfig {
  std::string source = "synthetic:";  // source URI (see `edgefusion --help`)
  int width = 320;                    // working resolution, pixels (tracking and label fusion)
  int height = 240;
  int64_t max_frames = -1;            // frames to process; -1 = all the source has
  std::string out_dir;                // output folder; required by `run`
  bool progress = true;               // progress line on stderr
  bool write_map = true;              // write map.ply at the end of the run
  bool realtime = false;              // replays: pace frames by their timestamps (live sources are
                                      // paced by the camera anyway); default as fast as possible
  // Mapping (slam/surfel_slam.h), section `mapping`. Defaults are ElasticFusion's / SemanticFusion's.
  int64_t surfel_capacity = 1'000'000;  // surfels in the pool, allocated at start-up (1..100,000,000)
  double icp_weight = 10.0;             // tracking: relative weight of the ICP term (>= 0)
  double rgb_weight = 0.25;             // tracking: relative weight of the photometric term (>= 0)
  double rgb_boost_condition = 500.0;   // tracking: ICP condition number above which the RGB weight
                                        // rises (0 = off, else > 1; slam::TrackerOptions)
  double rgb_boost_max = 16.0;          // tracking: the most it rises, a factor on rgb_weight (>= 1)
  bool constant_velocity_guess = true;   // tracking's guess: last pose x last motion (false: last pose)
  float depth_cutoff_m = 8.0f;          // depths beyond this are ignored, metres (> 0)
  int index_map_scale = 1;              // index map cells per working pixel along each axis (1..4)
  bool associate_at_tracked_pose = true;  // fusion's index map at the tracked pose (false: the
                                          // previous pose's; SurfelSlamOptions)
  // Semantics (SemanticFusion), section `labels`: the CNN every N-th frame, Bayesian label fusion
  // into the surfels, rendered label images.
  bool labels = true;                   // segment and fuse labels; false = geometry only
  std::string model;                    // .efm segmentation model; empty = the shipped model
  int label_every = 10;                 // CNN + Bayesian update every N frames (>= 1; paper: 10)
  std::string labels_out;               // folder for rendered class-id PNGs; empty = none
  int labels_out_every = 10;            // write the rendering of every K-th frame (>= 1)
  std::string labels_final_out;         // folder for the final map's labels rendered into every
                                        // labels_out_every-th frame of a second reading of the
                                        // recording (pipeline/final_labels.h); empty = none
  bool label_visibility = true;         // fuse / render only surfels whose depth matches the measured
                                        // depth (semantic/visibility.h); false = every index-map surfel
  // Dense CRF over the map, section `crf`.
  int crf_every = 0;                    // dense CRF over the map every M frames; 0 = off (paper: 500)
  bool crf_final = false;               // one dense CRF over the map at the end of the run
  int crf_iterations = 10;              // mean-field iterations per CRF run (1..100; paper: 10)
  // Threads, section `pipeline` (pipeline/run_pipeline.h). The outputs are the same in every mode.
  int threads = 2;          // 1: every step (front: read, resample, preprocess; the CNN; mapping)
                            // takes its turn on one thread (deterministic order); 2: front and CNN on
                            // one thread, mapping on another; 3: front, CNN and mapping each on its
                            // own. A live camera always has its capture thread too.
  int prepared_slots = 3;   // frames in flight between the steps (2..16); a step waits for the one
                            // before it, so nothing is dropped there
  int capture_slots = 4;    // live cameras: frames between the capture thread and the front step
                            // (2..64); when full the oldest waiting frame is dropped and counted
  int front_cpu = -1;       // CPU core each thread is pinned to (0..cores-1); -1 = not pinned
  int cnn_cpu = -1;
  int mapping_cpu = -1;
  int capture_cpu = -1;
  // Fixed memory, section `memory` (pipeline/memory_plan.h).
  // Front panel (platform/devices/gpio.h): status LED and start/stop button; none by default. The
  // button is wired to ground (active low) unless the file says otherwise.
  GpioOptions gpio;
  int64_t memory_budget_mb = 256;       // a run refuses to start when its memory plan exceeds this,
                                        // MB = 10^6 bytes (1..1,000,000)

};

}  // namespace ef::pipeline
