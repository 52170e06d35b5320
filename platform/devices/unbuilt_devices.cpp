// Stand-ins for the device back-ends whose package was missing when CMake configured this build
// (platform/CMakeLists.txt leaves their .cpp out): each open function says what is missing.
#include "platform/devices/cameras.h"
#include "platform/devices/gpio.h"

namespace ef {

namespace {
[[maybe_unused]] Error not_built(const std::string& what, const char* package) {
  return error(ErrorCode::kUnsupported, what + ": not built: missing package " + package +
                                            " when this build was configured (scripts/install-deps.sh installs "
                                            "it; then configure again)");
}
}  // namespace

#ifndef EF_HAVE_OPENNI2
Result<std::unique_ptr<CameraSource>> open_openni2_camera(const SourceUri& uri) {
  return not_built(uri.scheme + ":" + uri.path, "libopenni2-dev (OpenNI2)");
}
bool openni2_built() { return false; }
#endif

#ifndef EF_HAVE_V4L2
Result<std::unique_ptr<CameraSource>> open_v4l2_camera(const SourceUri& uri) {
  return not_built(uri.scheme + ":" + uri.path, "libv4l-dev (V4L2)");
}
bool v4l2_built() { return false; }
#endif

#ifndef EF_HAVE_GPIOD
Result<std::unique_ptr<GpioOutputLine>> open_gpio_output(const GpioLineConfig& config, const char*) {
  return not_built("GPIO chip '" + config.chip + "'", "libgpiod-dev (libgpiod 1.x)");
}
Result<std::unique_ptr<GpioInputLine>> open_gpio_input(const GpioLineConfig& config, const char*, bool) {
  return not_built("GPIO chip '" + config.chip + "'", "libgpiod-dev (libgpiod 1.x)");
}
bool gpiod_built() { return false; }
#endif

}  // namespace ef
