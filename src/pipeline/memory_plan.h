// The fixed memory of `edgefusion run`, known before anything large is allocated: frames, SLAM
// buffers, the surfel pool (label store included), the segmenter (model, activation arena, packed
// weights, buffers), label fusion, the dense CRF and the class columns of map.ply. `edgefusion plan`
// prints it; `run` refuses to start when the total exceeds memory.budget_mb (check_memory_budget).
//
// How: each part asks its class: a static bytes_for() of the options the class's create() gets
// (SurfelPool::bytes_for, DenseCrf::bytes_for, Segmenter::buffer_bytes_for, ...), so no size formula
// is written twice. The source comes from its probe (sources/open_source.h: a recording's real frame
// size, a camera's requested one). The only file read is the segmentation model (88 kB shipped), for
// its shapes, its arena (nn::plan_memory, which allocates nothing large) and the packed weight bytes
// of the convolution variants this CPU would pick. tests/pipeline/test_memory_plan.cpp creates each
// object and checks the plan against what it allocated.
//
// Not counted: what the frame source holds inside (decoders, a synthetic room, driver buffers),
// stacks, the C++ / libc heap overhead, and code.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/result.h"
#include "pipeline/run_config.h"
#include "sources/open_source.h"

namespace ef::pipeline {

struct MemoryPart {
  std::string name;    // "surfel pool"
  std::size_t bytes;   // allocated at start-up
  std::string detail;  // the formula with its numbers, e.g. "1000000 surfels x 60 bytes"
};

struct MemoryPlan {
  std::vector<MemoryPart> parts;  // in start-up order
  std::size_t total_bytes = 0;    // sum of the parts
  std::size_t budget_bytes = 0;   // memory.budget_mb x 10^6
  int64_t crf_nodes = 0;          // the dense CRF's capacity (crf_nodes()); 0 when no CRF runs
  bool within_budget() const { return total_bytes <= budget_bytes; }
  // The bytes of the part named `name`; 0 when there is none.
  std::size_t bytes_of(const std::string& name) const;
  // A table: part, bytes, MB, detail; then the total and the budget.
  std::string table() const;
};

// The dense CRF's capacity in surfels: crf.capacity, or when it is 0 the pool's capacity, but no
// more than fit in what the budget leaves after `other_bytes` (every other part of the plan), and
// at least kMinCrfNodes (a plan that leaves less is over budget anyway and says so).
constexpr int64_t kMinCrfNodes = 1000;
int64_t crf_nodes(const RunConfig& config, std::size_t other_bytes, std::size_t budget_bytes);

// The plan of `config` for a source of `probe` (sources/open_source.h). Errors: the model file's
// (missing: kNotFound naming it; invalid: the loader's) when labels are on.
Result<MemoryPlan> plan_memory(const RunConfig& config, const SourceProbe& probe);
// The same for config.run.source, probed (probe_source: a recording is opened and closed; its errors).
Result<MemoryPlan> plan_memory(const RunConfig& config);

// What `run` checks before it allocates anything large, and `plan` with it: the configuration
// (RunConfig::validate), the source against it (check_run), the model file and the memory plan.
// The plan is returned even when it exceeds the budget (check_memory_budget says so).
Result<MemoryPlan> check_and_plan(const RunConfig& config, const SourceProbe& probe);

// Ok when plan_memory(config) succeeds and fits the budget. Otherwise kResourceExhausted with the
// total, the budget and the largest parts, and what to change (or plan_memory's error).
Status check_memory_budget(const RunConfig& config);
// The same for a plan already made from `config`.
Status check_memory_budget(const MemoryPlan& plan, const RunConfig& config);

}  // namespace ef::pipeline
