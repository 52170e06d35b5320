// libgpiod lines: errors for chips that are not there, optional GPIO, and a real chip when present.
#include <gtest/gtest.h>

#include <filesystem>

#include "platform/devices/gpio.h"

namespace ef {
namespace {

std::string first_gpio_chip() {
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator("/dev", ec))
    if (e.path().filename().string().rfind("gpiochip", 0) == 0) return e.path().string();
  return {};
}

// The front panel's usual wiring is the default: the LED drives its pin high, the push button pulls
// its biased-up pin to ground (active low), so a configuration names only chips and lines.
TEST(Gpio, DefaultsMatchAButtonToGroundAndAnLedDrivenHigh) {
  const GpioOptions options;
  EXPECT_FALSE(options.led.used());
  EXPECT_FALSE(options.button.used());
  EXPECT_FALSE(options.led.active_low);
  EXPECT_TRUE(options.button.active_low);
  EXPECT_TRUE(options.button_pull_up);
}

TEST(Gpio, MissingChipIsAnErrorNamingIt) {
  GpioLineConfig config;
  config.chip = "gpiochip-edgefusion-test-missing";
  config.offset = 3;
  auto out = open_gpio_output(config, "edgefusion-test");
  ASSERT_FALSE(out.ok());
  EXPECT_NE(out.error().message.find("gpiochip-edgefusion-test-missing"), std::string::npos) << out.error().message;
  if (gpiod_built()) {
    EXPECT_EQ(out.error().code, ErrorCode::kNotFound) << out.error().message;
  } else {
    EXPECT_EQ(out.error().code, ErrorCode::kUnsupported);
    EXPECT_NE(out.error().message.find("not built: missing package libgpiod-dev"), std::string::npos);
  }
  auto in = open_gpio_input(config, "edgefusion-test", true);
  ASSERT_FALSE(in.ok());
  EXPECT_NE(in.error().message.find("gpiochip-edgefusion-test-missing"), std::string::npos) << in.error().message;
  // A path is looked up as a path.
  config.chip = "/dev/gpiochip-edgefusion-missing";
  auto by_path = open_gpio_output(config, "edgefusion-test");
  ASSERT_FALSE(by_path.ok());
  EXPECT_NE(by_path.error().message.find("/dev/gpiochip-edgefusion-missing"), std::string::npos);
}

TEST(Gpio, RequiredLinesFailOptionalLinesWarn) {
  GpioOptions options;
  options.led.chip = "gpiochip-missing-led";
  options.button.chip = "gpiochip-missing-button";
  auto required = open_gpio_lines(options);
  ASSERT_FALSE(required.ok());
  EXPECT_NE(required.error().message.find("status LED"), std::string::npos) << required.error().message;
  EXPECT_NE(required.error().message.find("gpiochip-missing-led"), std::string::npos) << required.error().message;

  options.optional = true;
  auto optional = open_gpio_lines(options);
  ASSERT_TRUE(optional.ok()) << optional.error().message;
  EXPECT_EQ(optional->led, nullptr);
  EXPECT_EQ(optional->button, nullptr);
  EXPECT_NE(optional->warnings.find("gpiochip-missing-led"), std::string::npos) << optional->warnings;
  EXPECT_NE(optional->warnings.find("gpiochip-missing-button"), std::string::npos) << optional->warnings;

  // Nothing configured: nothing opened, no warning.
  auto none = open_gpio_lines(GpioOptions{});
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(none->led, nullptr);
  EXPECT_TRUE(none->warnings.empty());
  EXPECT_NE(options.describe().find("button=gpiochip-missing-button:0 (active low)"), std::string::npos)
      << options.describe();
}

TEST(Gpio, RealChipLineOutOfRange) {
  const std::string chip = first_gpio_chip();
  if (chip.empty()) GTEST_SKIP() << "no /dev/gpiochip* on this machine: the real-chip test needs GPIO hardware";
  if (!gpiod_built()) GTEST_SKIP() << "built without libgpiod-dev";
  GpioLineConfig config;
  config.chip = chip;
  config.offset = 100000;  // no chip has that many lines
  auto out = open_gpio_output(config, "edgefusion-test");
  ASSERT_FALSE(out.ok());
  EXPECT_EQ(out.error().code, ErrorCode::kNotFound);
  EXPECT_NE(out.error().message.find("offset 100000"), std::string::npos) << out.error().message;
  // The chip itself opens: reading line 0 as an input either works or says why (busy, permission).
  config.offset = 0;
  auto in = open_gpio_input(config, "edgefusion-test", false);
  if (in.ok()) {
    EXPECT_TRUE((*in)->get().ok());
  } else {
    EXPECT_NE(in.error().message.find(chip), std::string::npos) << in.error().message;
  }
}

}  // namespace
}  // namespace ef
