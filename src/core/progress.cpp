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

void Progress::format_line(char* out, std::size_t size, const char* label, int64_t done, int64_t total_frames,
                           double elapsed, const char* extra, bool final_line) {
  const double fps = elapsed > 0 ? static_cast<double>(done) / elapsed : 0.0;
  char total[32] = "", eta[32] = "";
  if (total_frames > 0) std::snprintf(total, sizeof total, "/%lld", static_cast<long long>(total_frames));
  // A known length: the time left at the rate so far.
  if (total_frames > 0 && done > 0 && done < total_frames && !final_line) {
    const long long left =
        static_cast<long long>(elapsed * static_cast<double>(total_frames - done) / static_cast<double>(done) + 0.5);
    std::snprintf(eta, sizeof eta, "  ETA %lld:%02lld", left / 60, left % 60);
  }
  std::snprintf(out, size, "%s: frame %lld%s  %.1f fps  %.1f s%s%s%s", label, static_cast<long long>(done), total, fps,
                elapsed, eta, *extra ? "  " : "", extra);
}

std::string Progress::line(const std::string& label, int64_t done, int64_t total, double elapsed, const char* extra,
                           bool final_line) {
  char text[512];
  format_line(text, sizeof text, label.c_str(), done, total, elapsed, extra, final_line);
  return text;
}

void Progress::print(int64_t done, const char* extra, bool final_line) {
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  char text[512];
  format_line(text, sizeof text, label_.c_str(), done, total_, elapsed, extra, final_line);
  std::fprintf(stderr, "%s%s%s", tty_ ? "\r" : "", text, tty_ ? (final_line ? "\033[K\n" : "\033[K") : "\n");
  std::fflush(stderr);
}

}  // namespace ef
