// In-memory GPIO lines for tests and for runs on a machine without the front panel.
#pragma once

#include <cstddef>
#include <string>
#include <utility>

#include "platform/devices/gpio.h"

namespace ef {

// Records what is driven. `fail` makes set() return an error (to test error handling).
class FakeGpioOutputLine final : public GpioOutputLine {
 public:
  explicit FakeGpioOutputLine(std::string name = "fake:out") : name_(std::move(name)) {}
  Status set(bool active) override {
    if (fail) return error(ErrorCode::kIoError, name_ + ": simulated write failure");
    if (writes == 0 || active != value) ++changes;
    value = active;
    ++writes;
    return Status();
  }
  const std::string& name() const override { return name_; }

  bool value = false;      // last level driven
  std::size_t writes = 0;  // set() calls that succeeded
  std::size_t changes = 0; // of those, the ones that changed the level (the first counts)
  bool fail = false;

 private:
  std::string name_;
};

// Returns `level` (set by the test). `fail` makes get() return an error.
class FakeGpioInputLine final : public GpioInputLine {
 public:
  explicit FakeGpioInputLine(std::string name = "fake:in") : name_(std::move(name)) {}
  Result<bool> get() override {
    if (fail) return error(ErrorCode::kIoError, name_ + ": simulated read failure");
    ++reads;
    return level;
  }
  const std::string& name() const override { return name_; }

  bool level = false;
  std::size_t reads = 0;
  bool fail = false;

 private:
  std::string name_;
};

}  // namespace ef
