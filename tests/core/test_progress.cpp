// The progress line of long runs (core/progress.h): frames, rate, time, and for a known length the
// time left (issue 33: a recording shows its ETA).
#include <gtest/gtest.h>

#include <string>

#include "core/progress.h"

namespace ef {
namespace {

TEST(Progress, AKnownLengthShowsTheTimeLeft) {
  // 250 of 1000 frames in 10 s: 25 fps, 750 frames left take 30 s.
  EXPECT_EQ(Progress::line("run", 250, 1000, 10.0, "tracking", false),
            "run: frame 250/1000  25.0 fps  10.0 s  ETA 0:30  tracking");
  // Over a minute: m:ss.
  EXPECT_EQ(Progress::line("convert", 100, 1000, 10.0, "", false), "convert: frame 100/1000  10.0 fps  10.0 s  ETA 1:30");
}

TEST(Progress, NoEtaWithoutALengthBeforeTheFirstFrameOrAtTheEnd) {
  EXPECT_EQ(Progress::line("run", 250, -1, 10.0, "", false), "run: frame 250  25.0 fps  10.0 s");  // a camera
  EXPECT_EQ(Progress::line("run", 0, 1000, 1.0, "", false), "run: frame 0/1000  0.0 fps  1.0 s");
  EXPECT_EQ(Progress::line("run", 1000, 1000, 40.0, "", true), "run: frame 1000/1000  25.0 fps  40.0 s");
}

}  // namespace
}  // namespace ef
