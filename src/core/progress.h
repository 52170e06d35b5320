// A progress line for long runs on stderr: rewritten in place on a terminal, one line every few
// seconds otherwise (logs, CI).
#pragma once

#include <chrono>
#include <cstddef>
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

  // The line's text (no terminal control): "run: frame 120/1000  30.0 fps  4.0 s  ETA 0:29  extra";
  // the ETA (the time left at the rate so far, m:ss) only while a known total is not reached.
  // format_line writes it into `out` (cut at `size`; no allocation: print() uses a stack buffer);
  // line() returns it (tests).
  static void format_line(char* out, std::size_t size, const char* label, int64_t done, int64_t total,
                          double elapsed_s, const char* extra, bool final_line);
  static std::string line(const std::string& label, int64_t done, int64_t total, double elapsed_s, const char* extra,
                          bool final_line);

 private:
  void print(int64_t done, const char* extra, bool final_line);
  std::string label_;
  int64_t total_;
  bool enabled_;
  bool tty_;
  std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace ef
