// SIGINT / SIGTERM as a request to stop: the run loop finishes the frame in hand, then writes the
// map, the trajectory and the statistics and exits 0 (a systemd stop, or Ctrl-C, loses nothing
// that was mapped). A second signal while the outputs are written is ignored (they take at most
// seconds); the final-labels pass after them (--labels-final-out, a second reading of the recording)
// stops at a signal that arrives during it (signals() counts them).
//
// Async-signal-safe: the handler only stores into a volatile sig_atomic_t.
#pragma once

#include <csignal>

namespace ef::app {

// Installs the handlers for its lifetime and restores the previous ones afterwards (so that
// in-process callers, such as tests, get their own handlers back). Not reentrant: one at a time.
class StopSignalScope {
 public:
  StopSignalScope();
  ~StopSignalScope();
  StopSignalScope(const StopSignalScope&) = delete;
  StopSignalScope& operator=(const StopSignalScope&) = delete;

  // True once SIGINT or SIGTERM arrived since construction.
  bool stop_requested() const;
  // The signal number that asked to stop (0 if none).
  int signal_number() const;
  // How many SIGINT / SIGTERM arrived since construction.
  int signals() const;

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
};

}  // namespace ef::app
