#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "test_support.h"

// ThreadSanitizer suppressions for every test binary (read at start-up when built with
// -fsanitize=thread; an unused symbol otherwise). libOpenNI2 (linked through the camera sources)
// unlocks in its own teardown a mutex it never locked; the report is the library's, not ours, and
// names only frames inside it.
extern "C" const char* __tsan_default_suppressions();
extern "C" const char* __tsan_default_suppressions() {
  return "mutex:libOpenNI2.so\n"
         "called_from_lib:libOpenNI2.so\n";
}

namespace {

// Removes the scratch folders of a test that passed (test::scratch_dir registers them). A failed
// test's folders stay for the reader of the failure, and so do all with EF_KEEP_TEST_FILES=1.
class ScratchCleanup : public ::testing::EmptyTestEventListener {
  void OnTestEnd(const ::testing::TestInfo& info) override {
    auto& dirs = ef::test::scratch_dirs_of_running_test();
    const char* keep_env = std::getenv("EF_KEEP_TEST_FILES");
    const bool keep = info.result()->Failed() || (keep_env && std::strcmp(keep_env, "1") == 0);
    for (const auto& dir : dirs) {
      if (keep) {
        std::fprintf(stderr, "[ scratch  ] kept %s\n", dir.c_str());
        continue;
      }
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
      if (ec) std::fprintf(stderr, "[ scratch  ] could not remove %s: %s\n", dir.c_str(), ec.message().c_str());
    }
    dirs.clear();
  }
};

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  // gtest owns the listener once appended.
  ::testing::UnitTest::GetInstance()->listeners().Append(new ScratchCleanup);
  return RUN_ALL_TESTS();
}
