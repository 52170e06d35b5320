// Helpers shared by the tests: where the shared research data is, scratch folders, a small disk.
#pragma once

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <sys/mount.h>
#include <unistd.h>

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

// True in the sanitizer builds (ASan + UBSan, TSan: 5-20x slower than a release build). They look
// for memory, undefined-behaviour and threading faults, which a sequence test's short form (the one
// qemu runs) reaches as well; its full length is run by the release build.
inline constexpr bool kUnderSanitizer =
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
    true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
    true;
#else
    false;
#endif
#else
    false;
#endif

// Why a test of process, signal and file-system behaviour through the command line (SIGKILL,
// SIGTERM, a full disk, a resume) skips under qemu-user: what it checks is the host kernel's and the
// same C++ as natively, 20-60x slower; the ARM code such a run goes through is the library's, whose
// own tests run under qemu (Checkpoint.*, Pipeline.*, SurfelSlam.*, the package phase's mapping).
inline constexpr const char* kProcessTestUnderEmulator =
    "under qemu-user: a test of the host's process and file behaviour; the ARM code it runs is covered by "
    "the library tests";

// Why one of the longest sequence tests (a minute or more under qemu-user) skips there: it checks
// tracking, fusion or the renderer over a sequence, in C++ that has no ARM-specific path; the ARM
// arithmetic it runs is the kernels' (bit-exact against their scalar twins under qemu in
// test_kernels and test_nn), and shorter sequence tests of the same module still run under qemu.
inline constexpr const char* kLongSequenceTestUnderEmulator =
    "under qemu-user: one of the longest sequence tests; its kernels are checked bit-exact under qemu and "
    "shorter sequence tests of the module run here";

// The heavy sequence tests take their short form: under qemu-user or a sanitizer.
inline constexpr bool kShortForm = kUnderEmulator || kUnderSanitizer;

// Frames of a sequence test: `native`, or `emulated` in the short form (qemu-user, sanitizers).
constexpr int frames_native_or_emulated(int native, int emulated) { return kShortForm ? emulated : native; }

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

// A small file system of its own (tmpfs of `bytes`) mounted on a scratch folder, for full-disk
// tests; unmounted when destroyed. Mounting needs root (CAP_SYS_ADMIN): where it fails, ok() is
// false and why() says so, and the test skips with that reason (EF_SKIP_WITHOUT_SMALL_DISK).
class SmallDisk {
 public:
  SmallDisk(const std::string& test_name, std::size_t bytes) : dir_(scratch_dir(test_name) / "disk") {
    std::filesystem::create_directories(dir_);
    const std::string options = "size=" + std::to_string(bytes);
    if (::mount("tmpfs", dir_.c_str(), "tmpfs", 0, options.c_str()) == 0) mounted_ = true;
    else why_ = "cannot mount a small tmpfs for a full-disk test (" + std::string(std::strerror(errno)) + "; needs root)";
  }
  ~SmallDisk() {
    if (mounted_) ::umount2(dir_.c_str(), MNT_DETACH);
  }
  SmallDisk(const SmallDisk&) = delete;
  SmallDisk& operator=(const SmallDisk&) = delete;
  bool ok() const { return mounted_; }
  const std::string& why() const { return why_; }
  const std::filesystem::path& dir() const { return dir_; }

 private:
  std::filesystem::path dir_;
  bool mounted_ = false;
  std::string why_;
};

}  // namespace ef::test

#define EF_SKIP_WITHOUT_SMALL_DISK(disk) \
  if (!(disk).ok()) GTEST_SKIP() << (disk).why()

#define EF_SKIP_WITHOUT_DATASET(var, name)                                                   \
  const std::filesystem::path var = ::ef::test::shared_dataset(name);                       \
  if (var.empty()) GTEST_SKIP() << "shared dataset '" << name << "' not found (looked in "  \
                                << EF_SHARED_DATA_DIR << " and $EF_SHARED_DATA)"
