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
                                            "checkpoint.prev.efs", "config.yaml", "log.mcap"};
inline constexpr const char* kTimePlaceholder = "{time}";

// Ok when `out` can take a new run: it has "{time}", does not exist, or holds no run's outputs (or
// overwrite, or resume: continuing it). Error (kInvalidArgument) naming the folder, the outputs found and the ways out.
Status check_out_folder(const RunOptions& run, const OutputOptions& output);

// Creates the run's folder and returns its path: "{time}" replaced (`now`: the start time), the
// `latest` link updated; an earlier run's outputs removed (overwrite); leftovers removed. With
// output.resume the folder must exist and keeps its outputs (the run continues them). Errors name
// the folder and the reason.
Result<std::string> prepare_out_folder(const RunOptions& run, const OutputOptions& output, std::time_t now);

}  // namespace ef::pipeline
