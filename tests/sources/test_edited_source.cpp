// Recordings with frames cut out and blank frames put in (sources/edited_source.h), through
// open_source() as the user gives them.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "sources/open_source.h"

namespace ef {
namespace {

struct Seen {
  std::vector<double> stamps;
  std::vector<std::string> names;
  std::vector<bool> blank;   // every depth pixel 0 and every colour pixel black
  std::vector<bool> has_pose;
  std::vector<int64_t> index;
};

Seen read_all(const std::string& uri, int64_t* frame_count = nullptr) {
  auto source = open_source(uri);
  EXPECT_TRUE(source.ok()) << (source.ok() ? "" : source.error().message);
  Seen s;
  if (!source.ok()) return s;
  if (frame_count) *frame_count = (*source)->info().frame_count;
  Frame f;
  for (;;) {
    auto got = (*source)->next(f);
    EXPECT_TRUE(got.ok());
    if (!got.ok() || !*got) break;
    bool blank = true;
    for (int y = 0; y < f.depth.height() && blank; ++y)
      for (int x = 0; x < f.depth.width(); ++x)
        if (f.depth(x, y) != 0.0f || f.color(x, y).r || f.color(x, y).g || f.color(x, y).b) { blank = false; break; }
    s.stamps.push_back(f.timestamp);
    s.names.push_back(f.name);
    s.blank.push_back(blank);
    s.has_pose.push_back(f.has_pose);
    s.index.push_back(f.index);
  }
  return s;
}

const char* kRoom = "synthetic:?frames=12&size=32x24";

TEST(EditedSource, CutLeavesOutTheFramesAndKeepsTheOthersStamps) {
  const Seen whole = read_all(kRoom);
  ASSERT_EQ(whole.stamps.size(), 12u);
  int64_t count = 0;
  const Seen cut = read_all(std::string(kRoom) + "&cut=3-6", &count);
  EXPECT_EQ(count, 8);
  ASSERT_EQ(cut.stamps.size(), 8u);
  const int kept[] = {0, 1, 2, 7, 8, 9, 10, 11};
  for (int i = 0; i < 8; ++i) {
    EXPECT_EQ(cut.stamps[i], whole.stamps[kept[i]]) << i;
    EXPECT_EQ(cut.names[i], whole.names[kept[i]]) << i;
    EXPECT_EQ(cut.index[i], i);
    EXPECT_FALSE(cut.blank[i]);
  }
}

TEST(EditedSource, CutToTheEndEndsTheStream) {
  const Seen cut = read_all(std::string(kRoom) + "&cut=9-100");
  EXPECT_EQ(cut.stamps.size(), 9u);
}

TEST(EditedSource, BlankFramesGoInAndLaterStampsMove) {
  const Seen whole = read_all(kRoom);
  int64_t count = 0;
  const Seen b = read_all(std::string(kRoom) + "&blank=5+3", &count);
  EXPECT_EQ(count, 15);
  ASSERT_EQ(b.stamps.size(), 15u);
  const double dt = 1.0 / 30.0;
  for (int i = 0; i < 15; ++i) {
    const bool is_blank = i >= 5 && i < 8;
    EXPECT_EQ(b.blank[i], is_blank) << i;
    EXPECT_EQ(b.index[i], i);
    if (i > 0) { EXPECT_GT(b.stamps[i], b.stamps[i - 1]) << i; }
    if (is_blank) {
      EXPECT_FALSE(b.has_pose[i]);
      EXPECT_EQ(b.names[i].rfind("blank-", 0), 0u) << b.names[i];
      EXPECT_NEAR(b.stamps[i], whole.stamps[4] + (i - 4) * dt, 1e-9);
    } else {
      const int src = i < 5 ? i : i - 3;
      EXPECT_TRUE(b.has_pose[i]);
      EXPECT_EQ(b.names[i], whole.names[src]);
      EXPECT_NEAR(b.stamps[i], whole.stamps[src] + (i < 5 ? 0.0 : 3 * dt), 1e-9) << i;
    }
  }
}

TEST(EditedSource, CutAndBlankTogether) {
  const Seen b = read_all(std::string(kRoom) + "&cut=2-4&blank=5+2");
  ASSERT_EQ(b.stamps.size(), 11u);  // 12 - 3 + 2
  EXPECT_FALSE(b.blank[1]);
  EXPECT_TRUE(b.blank[2]);
  EXPECT_TRUE(b.blank[3]);
  EXPECT_FALSE(b.blank[4]);
}

TEST(EditedSource, MalformedEditsAreErrorsNamingTheKey) {
  for (const char* q : {"&cut=5", "&cut=6-2", "&cut=a-b", "&blank=0+3", "&blank=4+0", "&blank=4", "&cut=2-6&blank=4+1",
                        "&cut=20-30", "&blank=12+1"}) {
    auto s = open_source(std::string(kRoom) + q);
    ASSERT_FALSE(s.ok()) << q;
    const std::string key = std::string(q).find("blank") != std::string::npos ? "blank" : "cut";
    EXPECT_NE(s.error().message.find(key), std::string::npos) << q << ": " << s.error().message;
  }
}

}  // namespace
}  // namespace ef
