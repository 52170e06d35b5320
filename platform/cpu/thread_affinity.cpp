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

std::string cpu_core_missing(int cpu) {
  const unsigned hw = std::thread::hardware_concurrency();
  if (cpu < 0 || cpu >= CPU_SETSIZE || (hw > 0 && static_cast<unsigned>(cpu) >= hw))
    return "core " + std::to_string(cpu) + " does not exist (this machine has cores 0.." +
           std::to_string(hw > 0 ? static_cast<int>(hw) - 1 : 0) + ")";
  return {};
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
