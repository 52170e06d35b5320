// GPIO lines through libgpiod 1.x (the v1 C API of Debian 12's libgpiod-dev 1.6). Built only when
// CMake finds libgpiod (EF_HAVE_GPIOD); unbuilt_devices.cpp has the stubs otherwise.
#include <gpiod.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>

#include "platform/devices/gpio.h"

namespace ef {

namespace {

// "/dev/gpiochip0, /dev/gpiochip1" or "none", for the message of a chip that is not there.
std::string list_chips() {
  std::string out;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/dev", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("gpiochip", 0) != 0) continue;
    if (!out.empty()) out += ", ";
    out += entry.path().string();
  }
  return out.empty() ? "none" : out;
}

// A requested line and its chip. Closing the chip releases the line too.
class GpiodLine {
 public:
  GpiodLine() = default;
  GpiodLine(const GpiodLine&) = delete;
  GpiodLine& operator=(const GpiodLine&) = delete;
  ~GpiodLine() {
    if (line_ != nullptr) gpiod_line_release(line_);
    if (chip_ != nullptr) gpiod_chip_close(chip_);
  }

  // Opens the chip and the line and requests it (output with `value`, or input).
  Status open(const GpioLineConfig& config, const char* consumer, bool output, int flags) {
    name_ = config.chip + ":" + std::to_string(config.offset);
    if (config.chip.empty()) return error(ErrorCode::kInvalidArgument, "no GPIO chip given");
    errno = 0;
    chip_ = gpiod_chip_open_lookup(config.chip.c_str());
    if (chip_ == nullptr) {
      const int err = errno;
      return error(err == ENOENT || err == ENODEV || err == 0 ? ErrorCode::kNotFound : ErrorCode::kIoError,
                   "GPIO chip '" + config.chip + "' " +
                       (err == ENOENT || err == ENODEV || err == 0 ? std::string("not found")
                                                                   : std::string("cannot be opened: ") + std::strerror(err)) +
                       " (looked up as a name, a path, a number and a label; chips present: " + list_chips() + ")");
    }
    const unsigned lines = gpiod_chip_num_lines(chip_);
    if (config.offset >= lines)
      return error(ErrorCode::kNotFound, "GPIO chip '" + config.chip + "' (" + gpiod_chip_name(chip_) + ") has " +
                                             std::to_string(lines) + " lines, no line at offset " +
                                             std::to_string(config.offset));
    line_ = gpiod_chip_get_line(chip_, config.offset);
    if (line_ == nullptr)
      return error(ErrorCode::kIoError, "GPIO " + name_ + ": cannot get the line: " + std::strerror(errno));
    if (config.active_low) flags |= GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW;
    const int rc = output ? gpiod_line_request_output_flags(line_, consumer, flags, 0)
                          : gpiod_line_request_input_flags(line_, consumer, flags);
    if (rc != 0) {
      const int err = errno;
      const char* holder = gpiod_line_consumer(line_);
      std::string why = std::strerror(err);
      if (err == EBUSY && holder != nullptr) why += std::string(" (held by '") + holder + "')";
      line_ = nullptr;  // not requested: nothing to release
      return error(ErrorCode::kIoError, "GPIO " + name_ + ": cannot request the line as " +
                                            (output ? "an output" : "an input") + ": " + why);
    }
    return Status();
  }

  gpiod_line* line() const { return line_; }
  const std::string& name() const { return name_; }

 private:
  gpiod_chip* chip_ = nullptr;
  gpiod_line* line_ = nullptr;
  std::string name_;
};

class GpiodOutput final : public GpioOutputLine {
 public:
  Status open(const GpioLineConfig& config, const char* consumer) { return line_.open(config, consumer, true, 0); }
  Status set(bool active) override {
    if (gpiod_line_set_value(line_.line(), active ? 1 : 0) != 0)
      return error(ErrorCode::kIoError, "GPIO " + line_.name() + ": cannot set the level: " + std::strerror(errno));
    return Status();
  }
  const std::string& name() const override { return line_.name(); }

 private:
  GpiodLine line_;
};

class GpiodInput final : public GpioInputLine {
 public:
  Status open(const GpioLineConfig& config, const char* consumer, bool pull_up) {
    return line_.open(config, consumer, false, pull_up ? GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_UP : 0);
  }
  Result<bool> get() override {
    const int v = gpiod_line_get_value(line_.line());
    if (v < 0)
      return error(ErrorCode::kIoError, "GPIO " + line_.name() + ": cannot read the level: " + std::strerror(errno));
    return v != 0;
  }
  const std::string& name() const override { return line_.name(); }

 private:
  GpiodLine line_;
};

}  // namespace

Result<std::unique_ptr<GpioOutputLine>> open_gpio_output(const GpioLineConfig& config, const char* consumer) {
  auto out = std::make_unique<GpiodOutput>();
  EF_RETURN_IF_ERROR(out->open(config, consumer));
  return std::unique_ptr<GpioOutputLine>(std::move(out));
}

Result<std::unique_ptr<GpioInputLine>> open_gpio_input(const GpioLineConfig& config, const char* consumer,
                                                       bool pull_up) {
  auto in = std::make_unique<GpiodInput>();
  EF_RETURN_IF_ERROR(in->open(config, consumer, pull_up));
  return std::unique_ptr<GpioInputLine>(std::move(in));
}

bool gpiod_built() { return true; }

}  // namespace ef
