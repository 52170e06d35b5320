// The robot's front panel logic: a status LED whose blink pattern says what the mapper is doing, and
// a debounced start/stop button. Both are driven by the run loop calling tick()/poll() with the time
// in milliseconds (any monotonic clock), so tests step time by hand. No heap use after construction.
//
// Threads: one thread (the run loop's) calls each object. Lines are borrowed and may be null (GPIO
// not configured, or optional and absent): the object then keeps its state and drives nothing.
#pragma once

#include <cstdint>

#include "core/result.h"
#include "platform/devices/gpio.h"

namespace ef {

enum class LedPattern {
  kOff,       // not running
  kTracking,  // steady on: capturing and tracking
  kLost,      // fast blink (4 Hz: 125 ms on, 125 ms off): tracking lost, or the camera vanished
  kLogging,   // slow blink (1 Hz: 500 ms on, 500 ms off): capture stopped, writing the outputs
};

const char* led_pattern_name(LedPattern pattern);

struct LedTiming {
  int64_t fast_half_period_ms = 125;  // kLost: on time = off time, milliseconds
  int64_t slow_half_period_ms = 500;  // kLogging: on time = off time, milliseconds
};

class StatusLed {
 public:
  explicit StatusLed(GpioOutputLine* line, LedTiming timing = {}) : line_(line), timing_(timing) {}

  // Selects a pattern; a blink starts with its "on" half at `now_ms`. Setting the current pattern
  // again keeps its phase. Takes effect at the next tick().
  void set_pattern(LedPattern pattern, int64_t now_ms);
  LedPattern pattern() const { return pattern_; }

  // Whether the LED should be lit at `now_ms` (times before the pattern start count as its start).
  bool lit_at(int64_t now_ms) const;

  // Drives the line to lit_at(now_ms). Writes only when the level changes (and on the first tick),
  // so calling it every frame costs nothing. An error is the line's (kIoError naming it).
  Status tick(int64_t now_ms);

 private:
  GpioOutputLine* line_;
  LedTiming timing_;
  LedPattern pattern_ = LedPattern::kOff;
  int64_t pattern_start_ms_ = 0;
  bool driven_ = false;   // a level has been written
  bool driven_level_ = false;
};

// A level that must hold for `debounce_ms` before it is believed (contact bounce of a push button
// lasts a few milliseconds). update() returns +1 on a debounced rising edge (inactive -> active),
// -1 on a falling edge, 0 otherwise. The first sample is taken as the stable level without an edge.
class Debouncer {
 public:
  explicit Debouncer(int64_t debounce_ms) : debounce_ms_(debounce_ms) {}
  int update(bool raw, int64_t now_ms);
  bool stable() const { return stable_; }

 private:
  int64_t debounce_ms_;
  bool started_ = false;
  bool stable_ = false;     // debounced level
  bool candidate_ = false;  // last raw level seen
  int64_t candidate_since_ms_ = 0;
};

// Start/stop push button: each debounced press (inactive -> active edge) toggles running().
class StartStopButton {
 public:
  StartStopButton(GpioInputLine* line, int64_t debounce_ms, bool initially_running = false)
      : line_(line), debouncer_(debounce_ms), running_(initially_running) {}

  // Reads the line at `now_ms`. Returns true when this sample completed a press (running() just
  // toggled), false otherwise; an error is the line's. Poll at least every debounce_ms / 2 for
  // presses to be seen promptly (the run loop's frame rate is enough for 30 ms).
  Result<bool> poll(int64_t now_ms);
  bool running() const { return running_; }
  // For a run loop that stops on its own (end of a recording, camera lost).
  void set_running(bool running) { running_ = running; }

 private:
  GpioInputLine* line_;
  Debouncer debouncer_;
  bool running_;
};

}  // namespace ef
