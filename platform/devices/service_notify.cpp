#include "platform/devices/service_notify.h"

#include <cstdlib>

#ifdef EF_HAVE_SYSTEMD
#include <systemd/sd-daemon.h>
#endif

namespace ef {

bool ServiceNotifier::built_with_systemd() {
#ifdef EF_HAVE_SYSTEMD
  return true;
#else
  return false;
#endif
}

ServiceNotifier::ServiceNotifier() {
#ifdef EF_HAVE_SYSTEMD
  const char* socket = std::getenv("NOTIFY_SOCKET");
  enabled_ = socket != nullptr && *socket != '\0';
  uint64_t usec = 0;
  // > 0 only when $WATCHDOG_USEC is set and $WATCHDOG_PID (if set) is this process.
  if (enabled_ && sd_watchdog_enabled(/*unset_environment=*/0, &usec) > 0) watchdog_us_ = static_cast<int64_t>(usec);
#endif
}

void ServiceNotifier::send(const std::string& message) {
#ifdef EF_HAVE_SYSTEMD
  if (!enabled_) return;
  // A failed send is not the mapper's problem: systemd's watchdog notices the silence itself.
  if (sd_notify(/*unset_environment=*/0, message.c_str()) > 0) ++sent_;
#else
  (void)message;
#endif
}

void ServiceNotifier::ready(const std::string& status) { send("READY=1\nSTATUS=" + status); }

void ServiceNotifier::status(const std::string& status) { send("STATUS=" + status); }

void ServiceNotifier::stopping(const std::string& status) { send("STOPPING=1\nSTATUS=" + status); }

bool ServiceNotifier::alive(int64_t now_us, const char* status) {
  if (!enabled_ || watchdog_us_ <= 0) return false;
  if (last_ping_us_ >= 0 && now_us - last_ping_us_ < watchdog_us_ / 4) return false;
  last_ping_us_ = now_us;
  const int64_t before = sent_;
  send(status != nullptr ? "WATCHDOG=1\nSTATUS=" + std::string(status) : std::string("WATCHDOG=1"));
  if (sent_ == before) return false;
  ++pings_;
  return true;
}

}  // namespace ef
