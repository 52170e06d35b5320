// The run's output folder (issue 29: runs never overwrite runs).
//
// A folder holds a run when it has any of the run's outputs (kRunFiles). A new run into such a
// folder is refused unless output.overwrite, which removes the earlier run's outputs first, so a
// folder never mixes two runs (run A's map beside run B's trajectory).
//
// For a service that restarts into the same configuration, `out` may contain "{time}": each run
// then gets a folder of its own named by its start time (local time, YYYYmmdd-HHMMSS, with -2, -3,
// ... when two start within a second), and a symbolic link `latest` beside it points to the
// newest run's folder.
//
// Leftovers of a killed run are removed when a folder is prepared: "<file>.partial" (an output not
// yet renamed into place) and ".<file>.next" (stats.json's reserve), io/durable_file.h.
#pragma once

#include <ctime>
#include <string>

#include "core/result.h"
#include "pipeline/run_config.h"

namespace ef::pipeline {

// The outputs that make a folder a run's.
inline constexpr const char* kRunFiles[] = {"trajectory.txt", "map.ply", "stats.json", "checkpoint.efs",
                                            "checkpoint.prev.efs", "config.yaml", "log.mcap", "preview.png",
                                            "report.html"};
inline constexpr const char* kTimePlaceholder = "{time}";

// Ok when `out` can take a new run: it has "{time}", does not exist, or holds no run's outputs (or
// overwrite, or resume: continuing it). Error (kInvalidArgument) naming the folder, the outputs found and the ways out.
Status check_out_folder(const RunOptions& run, const OutputOptions& output);

// For a service that restarts after a power cut (output.resume_interrupted, issue 32): the run to
// continue instead of starting a new one. With "{time}" in the last part of `run.out`, the folder
// that `latest` beside it points to is one when its stats.json says "running" (the run was killed
// or the power went: it never wrote its end) or "camera lost" (the service restarts after a camera
// that vanished), and it has a usable checkpoint (find_checkpoint). Otherwise `folder` is empty and
// `why` says what was found ("no earlier run", "... ended: finished", "... has no usable
// checkpoint: ..."), for the start-up message.
struct InterruptedRun {
  std::string folder;  // the run folder to continue (the link resolved); empty = start a new run
  std::string state;   // its stats.json state
  int64_t frames = 0;  // frames its checkpoint holds
  std::string why;     // when folder is empty: why no run is continued
};
InterruptedRun find_interrupted_run(const RunOptions& run);

// The "state" of a run folder's stats.json ("running", "stopped", "camera lost", "finished",
// "failed: ..."), or empty when it has none or it cannot be read.
std::string run_state(const std::string& folder);

// Creates the run's folder and returns its path: "{time}" replaced (`now`: the start time), the
// `latest` link updated; an earlier run's outputs removed (overwrite); leftovers removed. With
// output.resume the folder must exist and keeps its outputs (the run continues them). Errors name
// the folder and the reason.
Result<std::string> prepare_out_folder(const RunOptions& run, const OutputOptions& output, std::time_t now);

}  // namespace ef::pipeline
