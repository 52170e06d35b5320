// Telling systemd how the mapper is doing (issue 32): `edgefusion run` under the shipped unit
// (Type=notify, WatchdogSec=) says when it is ready, shows its progress in `systemctl status`, and
// proves it is alive at every mapped frame, so that systemd restarts a mapper that hangs.
//
// The protocol is sd_notify(3) from libsystemd: datagrams to $NOTIFY_SOCKET; the watchdog interval
// comes from $WATCHDOG_USEC (for the process $WATCHDOG_PID). Outside systemd ($NOTIFY_SOCKET unset)
// or in a build without libsystemd (EF_HAVE_SYSTEMD undefined), every call does nothing.
//
// Threads: one thread (the run's mapping thread) calls everything. alive() is on the per-frame path:
// it sends at most one datagram per quarter of the watchdog interval, and nothing else.
#pragma once

#include <cstdint>
#include <string>

namespace ef {

class ServiceNotifier {
 public:
  // Reads the environment once (the variables stay set).
  ServiceNotifier();

  // True when notifications go somewhere: built with libsystemd and $NOTIFY_SOCKET given.
  bool enabled() const { return enabled_; }
  // The watchdog interval systemd expects a ping within, microseconds; 0 = no watchdog.
  int64_t watchdog_interval_us() const { return watchdog_us_; }
  // True when this build can talk to systemd at all (libsystemd linked).
  static bool built_with_systemd();

  // READY=1 with a status line: start-up is done (Type=notify waits for it).
  void ready(const std::string& status);
  // STATUS=: the line `systemctl status` shows.
  void status(const std::string& status);
  // WATCHDOG=1, with STATUS=<status> in the same datagram when given, once a quarter of the interval
  // has passed since the last ping (now_us: a monotonic clock, microseconds). Returns true when a
  // ping was sent.
  bool alive(int64_t now_us, const char* status = nullptr);
  // STOPPING=1 with a status line: the run is ending and writing its outputs.
  void stopping(const std::string& status);

  // Datagrams sent (each kind counted together) and watchdog pings among them, for tests and stats.
  int64_t sent() const { return sent_; }
  int64_t pings() const { return pings_; }

 private:
  void send(const std::string& message);

  bool enabled_ = false;
  int64_t watchdog_us_ = 0;
  int64_t last_ping_us_ = -1;
  int64_t sent_ = 0, pings_ = 0;
};

}  // namespace ef
