// Helpers of the camera tests: whether OpenNI2's Dummy driver is installed for this architecture.
#pragma once

#include <filesystem>
#include <string>

namespace ef::test {

// The folder where Debian's libopenni2-0 puts OpenNI2's drivers for the architecture of this build.
inline std::string openni2_driver_dir() {
#if defined(__aarch64__)
  return "/usr/lib/aarch64-linux-gnu/OpenNI2/Drivers";
#elif defined(__x86_64__)
  return "/usr/lib/x86_64-linux-gnu/OpenNI2/Drivers";
#else
  return "";
#endif
}

inline bool openni2_dummy_driver_installed() {
  std::error_code ec;
  return std::filesystem::exists(openni2_driver_dir() + "/libDummyDevice.so.0", ec);
}

}  // namespace ef::test
