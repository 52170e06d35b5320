// LeakSanitizer suppressions for this test binary: OpenNI2 and its drivers keep allocations they
// never free (the Dummy driver keeps every opened device in a table for the process lifetime;
// libOpenNI2 stays initialised until exit by design, platform/devices/openni2_source.cpp). Only
// allocations with a frame inside those libraries are suppressed; our own leaks are still reported.
// LeakSanitizer reads this hook at start-up when the binary is built with -fsanitize=address.
extern "C" const char* __lsan_default_suppressions();
extern "C" const char* __lsan_default_suppressions() {
  return "leak:libOpenNI2.so\n"
         "leak:libDummyDevice.so\n"
         "leak:libOniFile.so\n"
         "leak:libPS1080.so\n"
         "leak:libPSLink.so\n"
         "leak:libusb-1.0.so\n";
}
