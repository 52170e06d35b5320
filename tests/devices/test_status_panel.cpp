// Status LED patterns and the debounced start/stop button, against fake GPIO lines.
#include <gtest/gtest.h>

#include "platform/devices/fake_gpio.h"
#include "platform/devices/status_panel.h"

namespace ef {
namespace {

TEST(StatusLed, PatternsOverTime) {
  FakeGpioOutputLine line;
  StatusLed led(&line);
  ASSERT_TRUE(led.tick(0).ok());
  EXPECT_FALSE(line.value);  // off until told otherwise
  EXPECT_EQ(line.writes, 1u);

  led.set_pattern(LedPattern::kTracking, 10);
  for (int64_t t = 10; t < 3000; t += 7) {
    ASSERT_TRUE(led.tick(t).ok());
    EXPECT_TRUE(line.value) << "steady on at " << t;
  }
  EXPECT_EQ(line.writes, 2u) << "a steady level is written once";

  // Fast blink: 125 ms on, 125 ms off, starting on at the moment the pattern is set.
  led.set_pattern(LedPattern::kLost, 5000);
  const int64_t probes[][2] = {{5000, 1}, {5124, 1}, {5125, 0}, {5249, 0}, {5250, 1}, {5375, 0}, {6000, 1}};
  for (const auto& p : probes) {
    ASSERT_TRUE(led.tick(p[0]).ok());
    EXPECT_EQ(line.value, p[1] != 0) << "fast blink at " << p[0];
  }
  // Slow blink: 500 ms halves.
  led.set_pattern(LedPattern::kLogging, 10000);
  const int64_t slow[][2] = {{10000, 1}, {10499, 1}, {10500, 0}, {10999, 0}, {11000, 1}, {12600, 0}};
  for (const auto& p : slow) {
    ASSERT_TRUE(led.tick(p[0]).ok());
    EXPECT_EQ(line.value, p[1] != 0) << "slow blink at " << p[0];
  }
  led.set_pattern(LedPattern::kOff, 13000);
  ASSERT_TRUE(led.tick(13000).ok());
  EXPECT_FALSE(line.value);
}

TEST(StatusLed, WritesOnlyOnChangeAndKeepsPhase) {
  FakeGpioOutputLine line;
  StatusLed led(&line);
  led.set_pattern(LedPattern::kLost, 0);
  for (int64_t t = 0; t < 1000; ++t) ASSERT_TRUE(led.tick(t).ok());  // 1 kHz polling
  EXPECT_EQ(line.changes, 8u);  // on at 0, off 125, on 250, ... : 8 levels in one second
  EXPECT_EQ(line.writes, line.changes);
  // Setting the same pattern again does not restart the blink.
  led.set_pattern(LedPattern::kLost, 1130);
  EXPECT_FALSE(led.lit_at(1130));  // 1130 is in the off half that started at 1125
}

TEST(StatusLed, WithoutALineAndWithAFailingLine) {
  StatusLed none(nullptr);
  none.set_pattern(LedPattern::kTracking, 0);
  EXPECT_TRUE(none.tick(0).ok());
  EXPECT_TRUE(none.lit_at(0));

  FakeGpioOutputLine line("gpiochip0:17");
  line.fail = true;
  StatusLed led(&line);
  led.set_pattern(LedPattern::kTracking, 0);
  const Status s = led.tick(0);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("gpiochip0:17"), std::string::npos) << s.error().message;
  line.fail = false;
  EXPECT_TRUE(led.tick(1).ok());  // a failed write is retried at the next tick
  EXPECT_TRUE(line.value);
}

TEST(Debouncer, BouncesAreIgnored) {
  Debouncer d(30);
  EXPECT_EQ(d.update(false, 0), 0);
  // Contact bounce for 12 ms, then held: one rising edge, 30 ms after the last bounce.
  int edges = 0;
  int64_t rising_at = -1;
  for (int64_t t = 1; t <= 100; ++t) {
    const bool raw = t < 12 ? (t % 3 != 0) : true;
    const int e = d.update(raw, t);
    if (e != 0) {
      ++edges;
      EXPECT_EQ(e, +1);
      rising_at = t;
    }
  }
  EXPECT_EQ(edges, 1);
  EXPECT_EQ(rising_at, 40);  // last bounce at t = 10 (low at 9, high from 10), believed 30 ms later
  EXPECT_TRUE(d.stable());
  // A 20 ms glitch low is not a release.
  for (int64_t t = 101; t <= 120; ++t) EXPECT_EQ(d.update(false, t), 0);
  for (int64_t t = 121; t <= 200; ++t) EXPECT_EQ(d.update(true, t), 0);
  // A real release.
  int falling = 0;
  for (int64_t t = 201; t <= 260; ++t) falling += d.update(false, t) < 0;
  EXPECT_EQ(falling, 1);
}

TEST(StartStopButton, EachPressToggles) {
  FakeGpioInputLine line;
  StartStopButton button(&line, 30);
  int64_t t = 0;
  const auto hold = [&](bool level, int64_t ms, int* presses) {
    line.level = level;
    for (int64_t end = t + ms; t < end; t += 10) {  // polled every 10 ms, as a 100 Hz loop would
      auto r = button.poll(t);
      ASSERT_TRUE(r.ok());
      if (*r) ++*presses;
    }
  };
  int presses = 0;
  hold(false, 100, &presses);
  EXPECT_FALSE(button.running());
  hold(true, 200, &presses);  // press
  EXPECT_EQ(presses, 1);
  EXPECT_TRUE(button.running());
  hold(false, 200, &presses);  // release: no event
  EXPECT_EQ(presses, 1);
  EXPECT_TRUE(button.running());
  hold(true, 20, &presses);  // a tap shorter than the debounce time: ignored
  hold(false, 100, &presses);
  EXPECT_EQ(presses, 1);
  hold(true, 100, &presses);  // second press stops
  EXPECT_EQ(presses, 2);
  EXPECT_FALSE(button.running());
  button.set_running(true);
  EXPECT_TRUE(button.running());
}

TEST(StartStopButton, ReadErrorsAndNoLine) {
  FakeGpioInputLine line("gpiochip1:4");
  line.fail = true;
  StartStopButton button(&line, 30);
  auto r = button.poll(0);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("gpiochip1:4"), std::string::npos);
  StartStopButton none(nullptr, 30, true);
  auto n = none.poll(0);
  ASSERT_TRUE(n.ok());
  EXPECT_FALSE(*n);
  EXPECT_TRUE(none.running());
}

}  // namespace
}  // namespace ef
