// GPIO lines for the robot's status LED and start/stop button: one interface, a libgpiod back-end
// (gpiod_lines.cpp, Debian 12's libgpiod 1.6, the v1 C API) and a fake for tests (fake_gpio.h).
//
// Threads: a line object is used by one thread at a time (the run loop's); nothing here locks.
// Ownership: open_* functions return owning pointers; StatusLed and StartStopButton borrow lines.
#pragma once

#include <memory>
#include <string>

#include "core/options.h"
#include "core/result.h"

namespace ef {

// One output line (an LED). `active` is the logical level: with active_low the pin is driven low.
class GpioOutputLine {
 public:
  virtual ~GpioOutputLine() = default;
  // Drives the line. An error names the chip and offset (kIoError).
  virtual Status set(bool active) = 0;
  // "gpiochip0:17" style name for messages.
  virtual const std::string& name() const = 0;
};

// One input line (a button). get() returns the logical level: true = active (pressed), after
// active_low is applied.
class GpioInputLine {
 public:
  virtual ~GpioInputLine() = default;
  virtual Result<bool> get() = 0;
  virtual const std::string& name() const = 0;
};

// Where a line is: chip by name ("gpiochip0"), path ("/dev/gpiochip0"), number ("0") or label
// ("pinctrl-bcm2711"), as libgpiod's gpiod_chip_open_lookup() takes it; line offset on that chip.
struct GpioLineConfig {
  std::string chip;        // empty = this line is not used
  unsigned offset = 0;     // line offset on the chip (not a global GPIO number)
  bool active_low = false; // true when the LED / button is wired to pull the pin low when active
  bool used() const { return !chip.empty(); }
  std::string describe() const;  // "gpiochip0:17 (active low)"
  // The keys of one line (section gpio, bound as led_* and button_*): chip, line, active_low.
  static const opt::Table<GpioLineConfig>& table();
  Status validate() const;
};

// Opens an output line, driven inactive at first. Errors: kNotFound naming the chip when it does
// not exist, kNotFound naming the offset when the chip has no such line, kIoError when the line is
// busy or cannot be requested, kUnsupported when this build has no libgpiod.
Result<std::unique_ptr<GpioOutputLine>> open_gpio_output(const GpioLineConfig& config, const char* consumer);

// Opens an input line with the pull-up bias when `pull_up` (a button to ground; the kernel may
// ignore the bias on chips that cannot set it). Errors as open_gpio_output.
Result<std::unique_ptr<GpioInputLine>> open_gpio_input(const GpioLineConfig& config, const char* consumer,
                                                       bool pull_up);

// GPIO of the robot's front panel.
struct GpioOptions {
  GpioLineConfig led;       // status LED; unused when led.chip is empty (default)
  // Start/stop push button; unused when button.chip is empty (default). Active low by default: a
  // push button wired to ground, its line biased up (button_pull_up), reads low when pressed.
  GpioLineConfig button{std::string(), 0, /*active_low=*/true};
  bool button_pull_up = true;  // bias the button line up (the default wiring above)
  int debounce_ms = 30;     // a button level must hold this long, milliseconds, to count (default 30)
  bool optional = false;    // true: a missing chip or line is a warning and the run goes on
                            // without that line; false (default): it is an error
  std::string describe() const;  // one line, every field
  // The keys of the panel (section gpio): debounce_ms, optional; the lines' own in GpioLineConfig.
  static const opt::Table<GpioOptions>& table();
  Status validate() const;  // both lines and the fields above
};

// The lines of GpioOptions. A null pointer: the line is not configured, or it is optional and
// could not be opened (then `warnings` says why, one line per failure).
struct GpioLines {
  std::unique_ptr<GpioOutputLine> led;
  std::unique_ptr<GpioInputLine> button;
  std::string warnings;
};

// Opens the configured lines. With optional = false the first failure is returned as the error.
Result<GpioLines> open_gpio_lines(const GpioOptions& options);

// True when this build has the libgpiod back-end.
bool gpiod_built();

}  // namespace ef
