// Helpers shared by the tests: where the shared research data is, and scratch folders.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>
#include <unistd.h>
#include <vector>

namespace ef::test {

// ../shared/data beside the checkout, or $EF_SHARED_DATA. Empty when absent.
inline std::filesystem::path shared_data_dir() {
  if (const char* env = std::getenv("EF_SHARED_DATA"); env && *env) return env;
  std::filesystem::path p = EF_SHARED_DATA_DIR;
  std::error_code ec;
  return std::filesystem::is_directory(p, ec) ? p : std::filesystem::path();
}

// Path of a dataset folder under shared data, empty when absent (call GTEST_SKIP then).
inline std::filesystem::path shared_dataset(const std::string& name) {
  const auto root = shared_data_dir();
  if (root.empty()) return {};
  std::error_code ec;
  return std::filesystem::exists(root / name, ec) ? root / name : std::filesystem::path();
}

// True when the tests run under qemu-user (cross builds define EF_TESTS_UNDER_EMULATOR; 20-60x
// slower than native): the one place the macro is read, so tests branch on a constant.
inline constexpr bool kUnderEmulator =
#ifdef EF_TESTS_UNDER_EMULATOR
    true;
#else
    false;
#endif

// Frames of a sequence test: `native`, or `emulated` under qemu-user.
constexpr int frames_native_or_emulated(int native, int emulated) { return kUnderEmulator ? emulated : native; }

// Scratch folders made during the running test. test_main.cpp's listener removes them when the
// test passes; after a failure, or with EF_KEEP_TEST_FILES=1 set, it keeps them and prints where
// they are. Without this every ctest run left its folders (about 100 MB) in /tmp.
inline std::vector<std::filesystem::path>& scratch_dirs_of_running_test() {
  static std::vector<std::filesystem::path> dirs;
  return dirs;
}

// A fresh empty folder for one test's files, under the system temporary directory ($TMPDIR),
// removed when the test ends (above).
inline std::filesystem::path scratch_dir(const std::string& test_name) {
  auto dir = std::filesystem::temp_directory_path() / ("edgefusion-test-" + test_name + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  scratch_dirs_of_running_test().push_back(dir);
  return dir;
}

}  // namespace ef::test

#define EF_SKIP_WITHOUT_DATASET(var, name)                                                   \
  const std::filesystem::path var = ::ef::test::shared_dataset(name);                       \
  if (var.empty()) GTEST_SKIP() << "shared dataset '" << name << "' not found (looked in "  \
                                << EF_SHARED_DATA_DIR << " and $EF_SHARED_DATA)"
