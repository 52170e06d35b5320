// Pinning a thread to one CPU core (Linux sched_setaffinity), so that the pipeline's threads
// (src/pipeline/run_pipeline.h) do not migrate between the cores of a small board and compete with
// each other's caches. Optional everywhere: -1 means "let the kernel choose".
#pragma once

#include <string>
#include <vector>

namespace ef {

// Cores this process may run on (its affinity mask at start-up), at least 1.
int available_cpu_cores();
// Their numbers, ascending ({0, 1} on a two-core machine). Never empty.
std::vector<int> usable_cpu_cores();
// "cores 0-3", "cores 0, 2-3", "core 0".
std::string cores_text(const std::vector<int>& cores);

// Empty when core `cpu` (0-based) is one this process may use, else why not: "core 5 does not exist
// (this process may use cores 0-3)". The run's configuration is checked before any thread starts
// (pipeline::RunConfig::validate); pinning checks again.
std::string cpu_core_missing(int cpu);

// Pins the calling thread to core `cpu` (0-based). Returns an empty string on success, else why
// not: cpu_core_missing()'s text or the system's error text.
std::string pin_current_thread_to_cpu(int cpu);

// For a thread whose pinning is optional: cpu < 0 does nothing; a failure prints
// "warning: <thread_name> thread: <why>; it runs unpinned" to stderr and the thread goes on.
void pin_current_thread_or_warn(int cpu, const char* thread_name);

}  // namespace ef
