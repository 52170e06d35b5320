// FrameSource::skip (a resumed run passes over the frames its checkpoint holds): the frame after a
// skip is the frame a sequential reading gives there, for the indexed recordings (.klg, TUM,
// 7-Scenes) that skip without decoding.
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>

#include "io/frame_source.h"
#include "io/klg_format.h"
#include "io/sevenscenes_source.h"
#include "io/tum_source.h"
#include "io/tum_writer.h"
#include "test_support.h"

namespace ef {
namespace {

namespace fs = std::filesystem;
using Opener = std::function<Result<std::unique_ptr<FrameSource>>()>;

// Skipping n from the start, then reading, gives the sequential reading's frame n (depth and
// timestamp) for n below `frames`; skipping past the end says how many there were, and the stream
// has ended.
void expect_skip_matches_reading(const Opener& open, int frames) {
  auto seq = open();
  ASSERT_TRUE(seq.ok()) << to_string(seq.error());
  std::vector<Frame> all(static_cast<std::size_t>(frames));
  for (auto& f : all) ASSERT_TRUE(*(*seq)->next(f));
  for (int n : {0, 1, 3, frames - 1}) {
    auto s = open();
    ASSERT_TRUE(s.ok());
    Frame scratch, f;
    auto skipped = (*s)->skip(n, scratch);
    ASSERT_TRUE(skipped.ok());
    EXPECT_EQ(*skipped, n);
    ASSERT_TRUE(*(*s)->next(f)) << n;
    EXPECT_EQ(f.timestamp, all[std::size_t(n)].timestamp) << n;
    EXPECT_EQ(f.depth(f.depth.width() / 2, f.depth.height() / 2),
              all[std::size_t(n)].depth(f.depth.width() / 2, f.depth.height() / 2))
        << n;
  }
  auto s = open();
  Frame scratch, f;
  const int64_t count = (*s)->info().frame_count;
  auto skipped = (*s)->skip(count + 5, scratch);
  ASSERT_TRUE(skipped.ok());
  EXPECT_EQ(*skipped, count);
  EXPECT_FALSE(*(*s)->next(f));
}

void write_frames(const std::function<Status(const Frame&)>& write, int frames) {
  for (int i = 0; i < frames; ++i) {
    Frame f;
    f.allocate(8, 6, false);
    f.depth.fill(0.5f + 0.125f * float(i));
    f.color.fill(Rgb8{uint8_t(10 * i), 0, 0});
    f.timestamp = 10.0 + i / 30.0;
    f.name = "f" + std::to_string(i);
    ASSERT_TRUE(write(f).ok());
  }
}

TEST(SourceSkip, KlgAndTumSkipToTheSameFrameAsReading) {
  const auto dir = test::scratch_dir("source-skip");
  const std::string klg = (dir / "s.klg").string();
  {
    KlgWriter w;
    ASSERT_TRUE(w.open(klg, 8, 6).ok());
    write_frames([&](const Frame& f) { return w.write(f); }, 7);
    ASSERT_TRUE(w.close().ok());
  }
  expect_skip_matches_reading([&] { return open_klg(*parse_source_uri("klg:" + klg + "?size=8x6")); }, 7);
  {
    TumWriter w;
    ASSERT_TRUE(w.open((dir / "tum").string(), Intrinsics{}).ok());
    write_frames([&](const Frame& f) { return w.write(f); }, 7);
    ASSERT_TRUE(w.close().ok());
  }
  expect_skip_matches_reading([&] { return open_tum(*parse_source_uri("tum:" + (dir / "tum").string())); }, 7);
}

TEST(SourceSkip, SevenScenesSkipsToTheSameFrameAsReading) {
  EF_SKIP_WITHOUT_DATASET(data, "7scenes-redkitchen");
  expect_skip_matches_reading([&] { return open_7scenes(*parse_source_uri("7scenes:" + data.string())); }, 6);
}

}  // namespace
}  // namespace ef
