// Per-call stage timings in milliseconds on the steady clock (the Timings structs of the SLAM
// stages). No allocation.
#pragma once

#include <chrono>

namespace ef {

using SteadyClock = std::chrono::steady_clock;

// Milliseconds from t0 to now.
inline double ms_since(SteadyClock::time_point t0) {
  return std::chrono::duration<double, std::milli>(SteadyClock::now() - t0).count();
}

// Milliseconds from t to now, and t becomes now: consecutive laps of one function.
inline double lap_ms(SteadyClock::time_point& t) {
  const SteadyClock::time_point now = SteadyClock::now();
  const double ms = std::chrono::duration<double, std::milli>(now - t).count();
  t = now;
  return ms;
}

}  // namespace ef
