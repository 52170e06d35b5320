// The parts of gpio.h that do not depend on libgpiod (gpiod_lines.cpp or unbuilt_devices.cpp has
// the rest).
#include "platform/devices/gpio.h"

namespace ef {

std::string GpioLineConfig::describe() const {
  if (!used()) return "unused";
  return chip + ":" + std::to_string(offset) + (active_low ? " (active low)" : "");
}

std::string GpioOptions::describe() const {
  return "led=" + led.describe() + " button=" + button.describe() +
         " button_pull_up=" + (button_pull_up ? "true" : "false") + " debounce_ms=" + std::to_string(debounce_ms) +
         " optional=" + (optional ? "true" : "false");
}

Result<GpioLines> open_gpio_lines(const GpioOptions& options) {
  GpioLines lines;
  // An absent line is an error unless GPIO is optional; then the run goes on without it.
  const auto fail = [&](const char* what, Error err) -> Status {
    if (!options.optional) return error(err.code, std::string("GPIO ") + what + ": " + err.message);
    lines.warnings += std::string("warning: GPIO ") + what + " disabled: " + err.message + "\n";
    return Status();
  };
  if (options.led.used()) {
    auto led = open_gpio_output(options.led, "edgefusion-led");
    if (led.ok())
      lines.led = std::move(led).value();
    else
      EF_RETURN_IF_ERROR(fail("status LED", led.take_error()));
  }
  if (options.button.used()) {
    auto button = open_gpio_input(options.button, "edgefusion-button", options.button_pull_up);
    if (button.ok())
      lines.button = std::move(button).value();
    else
      EF_RETURN_IF_ERROR(fail("start/stop button", button.take_error()));
  }
  return lines;
}

}  // namespace ef
