#include <gtest/gtest.h>

// ThreadSanitizer suppressions for every test binary (read at start-up when built with
// -fsanitize=thread; an unused symbol otherwise). libOpenNI2 (linked through the camera sources)
// unlocks in its own teardown a mutex it never locked; the report is the library's, not ours, and
// names only frames inside it.
extern "C" const char* __tsan_default_suppressions();
extern "C" const char* __tsan_default_suppressions() {
  return "mutex:libOpenNI2.so\n"
         "called_from_lib:libOpenNI2.so\n";
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
