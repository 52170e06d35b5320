#include "core/progress.h"

#include <cstdio>
#include <unistd.h>

namespace ef {

namespace {
constexpr double kTtyPeriodS = 0.25;  // terminal refresh, seconds
constexpr double kLogPeriodS = 5.0;   // one log line every this many seconds when not a terminal
}  // namespace

Progress::Progress(std::string label, int64_t total, bool enabled)
    : label_(std::move(label)), total_(total), enabled_(enabled), tty_(isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()), last_(start_) {}

void Progress::update(int64_t done, const char* extra) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  const double since = std::chrono::duration<double>(now - last_).count();
  if (since < (tty_ ? kTtyPeriodS : kLogPeriodS)) return;
  last_ = now;
  print(done, extra, false);
}

void Progress::finish(int64_t done) {
  if (!enabled_) return;
  print(done, "", true);
}

void Progress::print(int64_t done, const char* extra, bool final_line) {
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double fps = elapsed > 0 ? static_cast<double>(done) / elapsed : 0.0;
  char total[32] = "";
  if (total_ > 0) std::snprintf(total, sizeof total, "/%lld", static_cast<long long>(total_));
  std::fprintf(stderr, "%s%s: frame %lld%s  %.1f fps  %.1f s%s%s%s", tty_ ? "\r" : "", label_.c_str(),
               static_cast<long long>(done), total, fps, elapsed, *extra ? "  " : "", extra,
               tty_ ? (final_line ? "\033[K\n" : "\033[K") : "\n");
  std::fflush(stderr);
}

}  // namespace ef
