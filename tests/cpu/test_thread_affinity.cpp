// Pinning threads to cores (platform/thread_affinity.h), as the pipeline does for its threads.
#include <gtest/gtest.h>

#include <sched.h>

#include <string>
#include <thread>

#include "platform/cpu/thread_affinity.h"

namespace ef {
namespace {

TEST(ThreadAffinity, PinsTheCallingThreadOnly) {
  ASSERT_GE(available_cpu_cores(), 1);
  cpu_set_t before;
  CPU_ZERO(&before);
  ASSERT_EQ(sched_getaffinity(0, sizeof before, &before), 0);
  int pinned_count = -1;
  bool on_core_zero = false;
  std::string why;
  std::thread t([&] {
    why = pin_current_thread_to_cpu(0);
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof set, &set) == 0) {
      pinned_count = CPU_COUNT(&set);
      on_core_zero = CPU_ISSET(0, &set);
    }
  });
  t.join();
  if (!CPU_ISSET(0, &before)) GTEST_SKIP() << "core 0 is not in this process's affinity mask";
  EXPECT_EQ(why, "");
  EXPECT_EQ(pinned_count, 1);
  EXPECT_TRUE(on_core_zero);
  // The test's own thread is untouched.
  cpu_set_t after;
  CPU_ZERO(&after);
  ASSERT_EQ(sched_getaffinity(0, sizeof after, &after), 0);
  EXPECT_TRUE(CPU_EQUAL(&before, &after));
}

TEST(ThreadAffinity, MissingCoreIsNamed) {
  std::string why;
  std::thread t([&] { why = pin_current_thread_to_cpu(4000); });
  t.join();
  EXPECT_NE(why.find("core 4000 does not exist"), std::string::npos) << why;
  std::thread u([&] { why = pin_current_thread_to_cpu(-1); });
  u.join();
  EXPECT_NE(why.find("core -1"), std::string::npos) << why;
  // The check alone, as configuration validation uses it: core 0 always exists.
  EXPECT_EQ(cpu_core_missing(0), "");
  EXPECT_NE(cpu_core_missing(4000).find("core 4000 does not exist"), std::string::npos);
}

TEST(ThreadAffinity, OptionalPinningWarnsAndGoesOn) {
  cpu_set_t before, after_none, after_bad;
  bool ok = true;
  std::thread t([&] {
    ok &= sched_getaffinity(0, sizeof before, &before) == 0;
    pin_current_thread_or_warn(-1, "test");  // not pinned: nothing changes
    ok &= sched_getaffinity(0, sizeof after_none, &after_none) == 0;
    testing::internal::CaptureStderr();
    pin_current_thread_or_warn(4000, "test");  // a missing core: a warning, the thread runs on
    const std::string warning = testing::internal::GetCapturedStderr();
    ok &= warning.find("warning: test thread: core 4000 does not exist") != std::string::npos;
    ok &= warning.find("runs unpinned") != std::string::npos;
    ok &= sched_getaffinity(0, sizeof after_bad, &after_bad) == 0;
  });
  t.join();
  EXPECT_TRUE(ok);
  EXPECT_TRUE(CPU_EQUAL(&before, &after_none));
  EXPECT_TRUE(CPU_EQUAL(&before, &after_bad));
}

}  // namespace
}  // namespace ef
