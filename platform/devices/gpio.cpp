// The parts of gpio.h that do not depend on libgpiod (gpiod_lines.cpp or unbuilt_devices.cpp has
// the rest).
#include "platform/devices/gpio.h"

namespace ef {

std::string GpioLineConfig::describe() const {
  if (!used()) return "unused";
  return chip + ":" + std::to_string(offset) + (active_low ? " (active low)" : "");
}

const opt::Table<GpioLineConfig>& GpioLineConfig::table() {
  static const opt::Table<GpioLineConfig> t = {
      {"chip", "", "", &GpioLineConfig::chip, "a chip name, /dev path, number or label", opt::any(),
       "GPIO chip (name, /dev path, number or label)"},
      {"line", "", "", &GpioLineConfig::offset, "", opt::between(0, 1023), "line offset on that chip"},
      {"active_low", "", "", &GpioLineConfig::active_low, "", opt::any(), "active when its pin is low"},
  };
  return t;
}

Status GpioLineConfig::validate() const { return opt::check_table(*this, table(), "gpio line"); }

const opt::Table<GpioOptions>& GpioOptions::table() {
  static const opt::Table<GpioOptions> t = {
      {"debounce_ms", "", "", &GpioOptions::debounce_ms, "milliseconds", opt::between(1, 1000),
       "a button level must hold this long to count"},
      {"optional", "", "", &GpioOptions::optional, "", opt::any(),
       "a missing chip or line is a warning and the run goes on without it"},
  };
  return t;
}

Status GpioOptions::validate() const {
  EF_RETURN_IF_ERROR(led.validate());
  EF_RETURN_IF_ERROR(button.validate());
  return opt::check_table(*this, table(), "gpio");
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
    lines.warnings += std::string("GPIO ") + what + " disabled: " + err.message + "\n";
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
