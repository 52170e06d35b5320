// The configuration of `edgefusion run` (and `edgefusion plan`): one options struct per part of the
// run, each with its own table of user-facing keys (core/options.h), bound here into sections:
//
//   (top level)  RunOptions                     source, resolution, frames, out, progress, map, realtime
//   mapping      slam::SurfelPoolOptions,       surfel_capacity; icp_weight, rgb_weight,
//                slam::TrackerOptions,          rgb_boost_condition, rgb_boost_max;
//                slam::SurfelSlamOptions,       constant_velocity_guess, associate_at_tracked_pose;
//                slam::PreprocessOptions,       depth_cutoff_m; index_map_scale
//                slam::PredictionOptions
//   labels       LabelOptions,                  enabled, model, out, out_every, final_out;
//                semantic::LabelFusionOptions   every, visibility
//   crf          CrfOptions,                    every, final;
//                semantic::DenseCrfOptions      iterations
//   pipeline     PipelineOptions                threads, prepared_slots, capture_slots, *_cpu
//   memory       MemoryOptions                  budget_mb
//   output       OutputOptions                  sync_seconds, stats_seconds, overwrite, checkpoint_seconds
//   gpio         GpioLineConfig (led_, button_), chip, line, active_low; debounce_ms, optional
//                GpioOptions
//
// Every key, its flat name, its command-line flag, unit, range, default and help come from those
// tables (config_keys()); adding an option is a row in its struct's table and the code that uses
// it. The YAML file and the command line are read in firmware_app/config_file.h.
//
// RunConfig::validate() holds everything that can be known wrong before a run starts: each struct's
// own validate() (ranges from its table, and its rules between fields), the rules between the parts
// of the run, and the machine (pinned cores that do not exist). check_run() adds the source (a live
// camera cannot be read twice). `run` and `plan` both call them, so `plan` refuses what `run` would.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/options.h"
#include "core/result.h"
#include "io/mcap_log.h"
#include "platform/devices/gpio.h"
#include "semantic/dense_crf.h"
#include "semantic/label_fusion.h"
#include "slam/surfel_slam.h"
#include "sources/open_source.h"

namespace ef::pipeline {

// The run as a whole (top-level keys).
struct RunOptions {
  std::string source = "synthetic:";        // frame source URI (sources/open_source.h)
  opt::ImageSize resolution{320, 240};      // working resolution of tracking and label fusion, pixels
  int64_t frames = -1;                      // frames to process; -1 = all the source has
  std::string out;                          // output folder; `run` needs it
  bool progress = true;                     // progress line on stderr
  bool map = true;                          // write map.ply at the end of the run
  bool preview = true;                      // write preview.png at the end (pipeline/map_preview.h)
  bool report = true;                       // write report.html at the end (pipeline/run_report.h)
  bool realtime = false;                    // replays paced by their timestamps (cameras pace themselves)

  static const opt::Table<RunOptions>& table();
  Status validate() const;
};

// Semantics (SemanticFusion) beyond the fusion itself: the network and the label images.
struct LabelOptions {
  bool enabled = true;          // segment and fuse labels; false = geometry only
  std::string model;            // .efm segmentation model; empty = the shipped one (model_paths.h)
  std::string out;              // folder for rendered class-id PNGs as frames arrive; empty = none
  int out_every = 10;           // write every K-th frame's rendering (frames)
  std::string final_out;        // folder for the finished map's labels rendered into every
                                // out_every-th frame of a second reading (pipeline/final_labels.h)

  static const opt::Table<LabelOptions>& table();
  Status validate() const;
};

// When the dense CRF runs over the map (its own options: semantic::DenseCrfOptions).
struct CrfOptions {
  int every = 0;       // every M frames; 0 = off (the paper: 500)
  bool final = false;  // once at the end of the run, before map.ply is written
  // Most surfels the CRF takes as nodes (its memory: semantic::DenseCrf::kBytesPerSurfel and 1.25
  // lattice vertices each); beyond it the confident surfels seen longest ago are left as fused
  // (DenseCrfOptions::capacity). 0 = derived: the pool's capacity, or fewer where the memory budget
  // leaves less after every other part of the plan (MemoryPlan::crf_nodes), so that a CRF run fits
  // the budget at any pool size.
  int64_t capacity = 0;

  static const opt::Table<CrfOptions>& table();
  Status validate() const;
  bool on() const { return every > 0 || final; }
};

// Threads of the pipeline (pipeline/run_pipeline.h).
struct PipelineOptions {
  // 1: every step (front: read, resample, preprocess; the CNN; mapping) takes its turn on one
  // thread (deterministic order); 2: front and the CNN's thread on one core, mapping on another;
  // 3: front, CNN and mapping each on its own. A live camera always has its capture thread too.
  int threads = 2;
  // The CNN takes exactly every due frame and mapping waits for each result at its own frame: the
  // outputs do not depend on timing (those of threads 1), and the mapping rate includes the CNN's.
  bool deterministic = false;
  int prepared_slots = 3;  // frames in flight between the steps; a step waits, nothing is dropped
  int capture_slots = 4;   // live cameras: frames between capture and the front step; full: the
                           // oldest waiting frame is dropped and counted
  int front_cpu = -1;      // the core each thread is pinned to; -1 = not pinned
  int cnn_cpu = -1;
  int mapping_cpu = -1;
  int capture_cpu = -1;
  // "keys": the *_cpu keys pin the threads; "auto": the cores are chosen at start-up from those
  // this process may use (pinned_for), so one configuration fits boards of any core count.
  std::string pinning = "keys";
  // Tests only (no key): milliseconds the CNN sleeps before each frame, a slow network.
  double test_cnn_delay_ms = 0;

  static const opt::Table<PipelineOptions>& table();
  Status validate() const;
  // These options with the *_cpu fields chosen from `cores` (ascending, never empty) when pinning is
  // "auto": mapping on the last core, the CNN on the one before, the front step on the one before
  // that, a live camera's capture thread on the first (with the kernel's interrupts); with fewer
  // than 4 cores the first ones are shared (3: capture + front, CNN, mapping; 2: capture + front +
  // CNN, mapping) and one core pins nothing. Unchanged with pinning "keys".
  PipelineOptions pinned_for(const std::vector<int>& cores) const;
  // "capture 0, front 1, CNN 2, mapping 3" or "none" (for the start-up line).
  std::string pinning_text() const;

  // Slots of the ring between the steps: one when a single thread takes every step in turn.
  int slots() const { return threads == 1 ? 1 : prepared_slots; }
};

// How the run's outputs reach the disk so that nothing accepted is lost (pipeline/run_outputs.h).
struct OutputOptions {
  double sync_seconds = 1;   // trajectory.txt synced at most this long after a line, s; 0 = every line
  double stats_seconds = 5;  // stats.json rewritten (state "running") this often, s; 0 = at start and end only
  bool overwrite = false;    // replace an earlier run's outputs in `out`; false = such a folder is refused
  double checkpoint_seconds = 30;  // a map checkpoint this often and at the end, s; 0 = none
  // `run --resume DIR` (no key): continue the run in `out` from its newest checkpoint.
  bool resume = false;
  // With "{time}" in `out`: continue the newest run there when it was interrupted (power cut, kill,
  // lost camera) and has a checkpoint, instead of starting a new one (pipeline/run_folder.h).
  bool resume_interrupted = false;

  static const opt::Table<OutputOptions>& table();
  Status validate() const;
};

// The fixed memory of a run (pipeline/memory_plan.h).
struct MemoryOptions {
  int64_t budget_mb = 256;  // a run refuses to start when its memory plan exceeds this, MB (10^6 bytes)

  static const opt::Table<MemoryOptions>& table();
  Status validate() const;
};

struct RunConfig {
  RunOptions run;
  slam::SurfelSlamOptions mapping;          // own_preprocessor is set by the mapping stage
  LabelOptions labels;
  semantic::LabelFusionOptions label_fusion;  // its image sizes are set by the semantics step
  CrfOptions crf;
  semantic::DenseCrfOptions dense_crf;      // its capacity and lattice come from crf_options_for_run
  PipelineOptions pipeline;
  MemoryOptions memory;
  OutputOptions output;
  McapLogOptions log;                       // the field log (io/mcap_log.h); log.file empty = none
  GpioOptions gpio;                         // front panel: status LED, start/stop button

  // Ok, or kInvalidArgument naming the key(s) and the value(s). `cores`: the cores this process may
  // use (platform/cpu/thread_affinity.h); a pinned core not among them is an error naming every
  // such key, what the machine has, and what to do.
  Status validate() const;
  Status validate(const std::vector<int>& cores) const;

  // A complete YAML configuration file: every key in its section with its value, and its help,
  // unit, range and default as a comment. Reading it back gives this configuration again. Empty
  // paths (out, model, label folders) are written as commented-out keys.
  std::string describe() const;
};

// The checks of the source and the output folder against the configuration: a live camera cannot
// be read twice (labels.final_out); a folder that holds a run is refused unless output.overwrite
// (pipeline/run_folder.h). With validate() and the memory plan, what `run` and `plan` check.
Status check_run(const RunConfig& config, const SourceProbe& source);

// The dense CRF's options for a run: config.dense_crf with a capacity of `nodes` (>= 1; the memory
// plan derives it: MemoryPlan::crf_nodes) and a lattice sized for a SurfelSlam map (the RunSemantics
// step and the memory plan both use it). Without `nodes`: crf.capacity, or the pool's capacity.
semantic::DenseCrfOptions crf_options_for_run(const RunConfig& config, int64_t nodes = 0);

// One key of the configuration: a row of an options table bound to its place in a RunConfig.
struct ConfigKey {
  std::string path;  // "mapping.icp_weight": the section, then the row's name
  std::string flat;  // the older top-level name, "" = none
  std::string flag;  // the command-line flag, "" = none
  std::string unit, help;
  opt::Range range;
  opt::Value::Kind kind = opt::Value::kInt;
  std::function<opt::Value(const RunConfig&)> get;
  // Sets the key from text; "" on success, else the complaint (the configuration is unchanged).
  std::function<std::string(RunConfig&, const std::string&)> parse;
  // A bool's flag: sets the opposite of its default.
  std::function<void(RunConfig&)> set_flag;

  std::string section() const;  // "mapping"; "" at the top level
  std::string name() const;     // "icp_weight"
  // "<help>, <unit>, <range>; default <default>".
  std::string doc() const;
};

// Every key, section by section, in file order.
const std::vector<ConfigKey>& config_keys();
// The key a section path ("crf.iterations") or a flat name ("crf_iterations") names; nullptr if none.
const ConfigKey* find_config_key(const std::string& key);
// The sections, in file order ("mapping", "labels", ...).
const std::vector<std::string>& config_sections();
// Every key as a Markdown table (key, flat name, flag, default, unit and range, help): the README's.
std::string config_keys_markdown();

}  // namespace ef::pipeline
