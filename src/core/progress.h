// A progress line for long runs on stderr: rewritten in place on a terminal, one line every few
// seconds otherwise (logs, CI).
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace ef {

class Progress {
 public:
  // label: "run", "convert"; total: frames expected, -1 when unknown; enabled: false prints nothing.
  Progress(std::string label, int64_t total, bool enabled);
  // Call once per frame; `extra` is appended to the line ("pose yes").
  void update(int64_t done, const char* extra = "");
  // Ends the line (prints the final state).
  void finish(int64_t done);

 private:
  void print(int64_t done, const char* extra, bool final_line);
  std::string label_;
  int64_t total_;
  bool enabled_;
  bool tty_;
  std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace ef
