#include "platform/cpu/thread_affinity.h"

#include <sched.h>

#include <cerrno>
#include <cstdio>
#include <system_error>
#include <thread>

namespace ef {

int available_cpu_cores() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) {
    const int n = CPU_COUNT(&set);
    if (n > 0) return n;
  }
  const unsigned hw = std::thread::hardware_concurrency();
  return hw > 0 ? static_cast<int>(hw) : 1;
}

std::vector<int> usable_cpu_cores() {
  std::vector<int> cores;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) {
    for (int c = 0; c < CPU_SETSIZE; ++c)
      if (CPU_ISSET(c, &set)) cores.push_back(c);
  }
  if (cores.empty()) {  // no affinity mask: every core the system reports
    const unsigned hw = std::thread::hardware_concurrency();
    for (int c = 0; c < static_cast<int>(hw > 0 ? hw : 1); ++c) cores.push_back(c);
  }
  return cores;
}

std::string cores_text(const std::vector<int>& cores) {
  std::string s;
  for (std::size_t i = 0; i < cores.size();) {
    std::size_t j = i;
    while (j + 1 < cores.size() && cores[j + 1] == cores[j] + 1) ++j;
    s += (s.empty() ? "" : ", ") + std::to_string(cores[i]) + (j > i ? "-" + std::to_string(cores[j]) : "");
    i = j + 1;
  }
  return (cores.size() == 1 ? "core " : "cores ") + s;
}

std::string cpu_core_missing(int cpu) {
  const std::vector<int> cores = usable_cpu_cores();
  for (int c : cores)
    if (c == cpu) return {};
  return "core " + std::to_string(cpu) + " does not exist (this process may use " + cores_text(cores) + ")";
}

std::string pin_current_thread_to_cpu(int cpu) {
  if (std::string why = cpu_core_missing(cpu); !why.empty()) return why;
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  // pid 0 = the calling thread (Linux affinity is per thread).
  if (sched_setaffinity(0, sizeof set, &set) != 0)
    return "cannot pin to core " + std::to_string(cpu) + ": " + std::error_code(errno, std::generic_category()).message();
  return {};
}

void pin_current_thread_or_warn(int cpu, const char* thread_name) {
  if (cpu < 0) return;
  const std::string why = pin_current_thread_to_cpu(cpu);
  if (!why.empty()) std::fprintf(stderr, "warning: %s thread: %s; it runs unpinned\n", thread_name, why.c_str());
}

}  // namespace ef
