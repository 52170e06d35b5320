// Files that are whole or absent (io/durable_file.h) and a trajectory of whole lines
// (io/trajectory_io.h), on a real full disk where this machine lets a test mount one.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "io/durable_file.h"
#include "io/ply_writer.h"
#include "io/stats_json.h"
#include "io/trajectory_io.h"
#include "test_support.h"

namespace ef {
namespace {

namespace fs = std::filesystem;

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

// Fills the file system of `dir` to the last byte with one file.
void fill_disk(const fs::path& dir) {
  std::ofstream out(dir / "filler", std::ios::binary);
  const std::string block(4096, 'x');
  while (out.write(block.data(), static_cast<std::streamsize>(block.size()))) {
  }
  // The last partial block: byte by byte until nothing more fits.
  out.clear();
  while (out.put('x') && out.flush()) {
  }
}

std::vector<std::string> names_in(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(FileReplacement, CommitReplacesTheFileWhole) {
  const auto dir = test::scratch_dir("replace-commit");
  const std::string path = (dir / "out.txt").string();
  write_text(path, "old version\n");
  FileReplacement r(path);
  EXPECT_EQ(r.temp_path(), path + ".partial");
  write_text(r.temp_path(), "new");
  EXPECT_EQ(read_all(path), "old version\n");  // until the commit, the earlier file stays
  ASSERT_TRUE(r.commit().ok());
  EXPECT_EQ(read_all(path), "new");
  EXPECT_FALSE(fs::exists(r.temp_path()));
  EXPECT_FALSE(r.commit().ok());  // once only
}

TEST(FileReplacement, AnAbandonedWriteLeavesTheEarlierFileAndNoPartial) {
  const auto dir = test::scratch_dir("replace-abandon");
  const std::string path = (dir / "out.txt").string();
  write_text(path, "old");
  {
    FileReplacement r(path, Durability::kAtomic);
    write_text(r.temp_path(), "half a fi");
  }  // destroyed without commit: a writer that failed
  EXPECT_EQ(read_all(path), "old");
  EXPECT_EQ(names_in(dir), std::vector<std::string>{"out.txt"});
  // A commit whose .partial was never written names the file.
  FileReplacement missing((dir / "never.txt").string());
  auto s = missing.commit();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("never.txt"), std::string::npos) << s.error().message;
}

TEST(WriteFileWhole, PiecesInOrderOrNothingOnAFullDisk) {
  const auto dir = test::scratch_dir("write-whole");
  const std::string path = (dir / "out.bin").string();
  const std::string a = "head:", b(1000, 'x');
  ASSERT_TRUE(write_file_whole(path, {{a.data(), a.size()}, {nullptr, 0}, {b.data(), b.size()}}).ok());
  EXPECT_EQ(read_all(path), a + b);
  EXPECT_EQ(names_in(dir), std::vector<std::string>{"out.bin"});

  test::SmallDisk disk("write-whole-full", 64 * 1024);
  EF_SKIP_WITHOUT_SMALL_DISK(disk);
  const std::string big(200 * 1024, 'y');
  const std::string full = (disk.dir() / "big.bin").string();
  auto s = write_file_whole(full, {{big.data(), big.size()}});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("big.bin"), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find("No space left on device"), std::string::npos) << s.error().message;
  EXPECT_TRUE(names_in(disk.dir()).empty());  // neither the file nor its .partial
}

TEST(RewrittenFile, EachVersionReplacesTheLastAndTheNextIsReserved) {
  const auto dir = test::scratch_dir("rewritten");
  const std::string path = (dir / "stats.json").string();
  RewrittenFile f;
  f.open(path, 4096);
  EXPECT_TRUE(f.reserved());
  EXPECT_TRUE(fs::exists(dir / ".stats.json.next"));
  EXPECT_EQ(fs::file_size(dir / ".stats.json.next"), 4096u);
  for (const std::string text : {"{\"state\":\"running\"}\n", "{\"state\":\"finished\",\"frames\":12}\n", "{}\n"}) {
    ASSERT_TRUE(f.write(text).ok());
    EXPECT_EQ(read_all(path), text);  // exactly the text: the reserve's tail was cut
    EXPECT_TRUE(f.reserved());
  }
}

// The reserve's purpose: on a disk that is full, the last version (a run's "failed") still fits.
TEST(RewrittenFile, TheLastVersionFitsOnAFullDisk) {
  test::SmallDisk disk("rewritten-full", 256 * 1024);
  EF_SKIP_WITHOUT_SMALL_DISK(disk);
  const std::string path = (disk.dir() / "stats.json").string();
  RewrittenFile f;
  f.open(path, 8192);
  ASSERT_TRUE(f.write("{\"state\":\"running\"}\n").ok());
  fill_disk(disk.dir());
  // Nothing else fits now...
  {
    std::ofstream more(disk.dir() / "more.txt", std::ios::binary);
    more << std::string(8192, 'y') << std::flush;
    EXPECT_FALSE(more.good()) << fs::space(disk.dir()).available << " bytes still free";
  }
  // ...but the next version does, in its reserved blocks.
  const std::string failed = "{\"state\":\"failed: " + std::string(3000, 'z') + "\"}\n";
  ASSERT_TRUE(f.write(failed).ok());
  EXPECT_EQ(read_all(path), failed);
  // A version larger than the reserve and the disk fails whole, naming the file and the reason,
  // and the last one stays.
  auto s = f.write(std::string(20000, 'w'));
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("stats.json"), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find("No space left on device"), std::string::npos) << s.error().message;
  EXPECT_EQ(read_all(path), failed);
}

TEST(DurableOutputs, APlyThatDoesNotFitLeavesTheEarlierMapAndNoPartial) {
  test::SmallDisk disk("ply-full", 512 * 1024);
  EF_SKIP_WITHOUT_SMALL_DISK(disk);
  const std::string path = (disk.dir() / "map.ply").string();
  std::vector<float> x(20000, 1.0f);
  SurfelCloudView small;
  small.count = 100;
  small.x = small.y = small.z = x.data();
  ASSERT_TRUE(write_surfel_ply(path, small).ok());
  const std::string earlier = read_all(path);
  SurfelCloudView big = small;
  big.count = x.size();  // 20000 x 40 bytes: more than the disk holds
  auto s = write_surfel_ply(path, big);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("map.ply"), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find("No space left on device"), std::string::npos) << s.error().message;
  EXPECT_EQ(read_all(path), earlier);
  EXPECT_EQ(names_in(disk.dir()), std::vector<std::string>{"map.ply"});
  auto back = read_surfel_ply(path);
  ASSERT_TRUE(back.ok()) << to_string(back.error());
  EXPECT_EQ(back->size(), 100u);
}

TEST(DurableOutputs, ATrajectoryOnAFullDiskKeepsWholeLinesOnly) {
  test::SmallDisk disk("traj-full", 64 * 1024);
  EF_SKIP_WITHOUT_SMALL_DISK(disk);
  const std::string path = (disk.dir() / "trajectory.txt").string();
  TumTrajectoryWriter w;
  ASSERT_TRUE(w.open(path, 0.0).ok());
  Status s;
  int written = 0;
  for (int i = 0; i < 100000 && s.ok(); ++i) {
    s = w.write(1000.0 + i / 30.0, SE3(Eigen::Quaterniond(0.9, 0.1, 0.3, -0.2).normalized(),
                                       Eigen::Vector3d(0.123456789 * i, -1.0 / (i + 3), 2.5)));
    if (s.ok()) ++written;
  }
  ASSERT_FALSE(s.ok()) << "the disk never filled";
  EXPECT_NE(s.error().message.find("trajectory.txt"), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find("No space left on device"), std::string::npos) << s.error().message;
  (void)w.close();
  const std::string text = read_all(path);
  ASSERT_FALSE(text.empty());
  EXPECT_EQ(text.back(), '\n');
  auto t = read_tum_trajectory(path);
  ASSERT_TRUE(t.ok()) << to_string(t.error());
  EXPECT_EQ(t->cut_line, 0);
  EXPECT_EQ(static_cast<int>(t->poses.size()), written);
}

TEST(TrajectoryReader, ACutLastLineIsLeftOutAndNamed) {
  const auto dir = test::scratch_dir("traj-cut");
  const std::string whole = "# timestamp tx ty tz qx qy qz qw\n1.000000 0 0 0 0 0 0 1\n2.000000 1 0 0 0 0 0 1\n";
  // Cut at every byte of the last line: never an error, never a half pose.
  const std::string last = "3.000000 0.5 0.25 0 0 0 0.7071 0.7071\n";
  for (std::size_t cut = 1; cut < last.size(); ++cut) {
    const std::string path = (dir / ("t" + std::to_string(cut) + ".txt")).string();
    write_text(path, whole + last.substr(0, cut));
    auto t = read_tum_trajectory(path);
    ASSERT_TRUE(t.ok()) << cut << ": " << to_string(t.error());
    // A cut that still parses as a whole pose (only the last digits of qw gone) is a pose.
    const bool parses = t->poses.size() == 3;
    EXPECT_EQ(t->cut_line != 0, !parses) << cut;
    if (!parses) {
      EXPECT_EQ(t->poses.size(), 2u) << cut;
      EXPECT_EQ(t->cut_line, 4);
      EXPECT_NE(t->cut_line_warning().find(path + ":4: the last line was cut"), std::string::npos);
    }
  }
  // The same line with its newline but broken is an error, not a cut.
  const std::string path = (dir / "bad.txt").string();
  write_text(path, whole + "3.000000 0.5 0.25\n");
  auto t = read_tum_trajectory(path);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().message.find("bad.txt:4"), std::string::npos) << t.error().message;
  // A last pose without its newline that is whole (files of other tools) is a pose.
  write_text(path, whole + "3.000000 0.5 0.25 0 0 0 0 1");
  t = read_tum_trajectory(path);
  ASSERT_TRUE(t.ok());
  EXPECT_EQ(t->poses.size(), 3u);
  EXPECT_EQ(t->cut_line, 0);
}

TEST(StatsJson, StateComesFirstAndTheTextIsRebuiltWithoutGrowing) {
  StageStats st;
  const int stage = st.add_stage("track");
  const int counter = st.add_counter("lost_frames");
  st.record_ms(stage, 2.0);
  st.increment(counter, 3);
  JsonWriter w;
  w.reserve(16 * 1024);
  const std::size_t capacity = w.str().capacity();
  write_stats_object(w, st, 10, 1.0, {{"surfels", 5}}, "running");
  const std::string first = w.str();
  EXPECT_EQ(first.rfind("{\"state\":\"running\",\"frames\":10,", 0), 0u) << first;
  write_stats_object(w, st, 11, 1.5, {{"surfels", 5}}, "failed: map.ply: No space left on device");
  EXPECT_EQ(w.str().rfind("{\"state\":\"failed: map.ply: No space left on device\",\"frames\":11,", 0), 0u) << w.str();
  EXPECT_EQ(w.str().capacity(), capacity);  // cleared and rewritten in place
  EXPECT_EQ(w.str().back(), '\n');
}

}  // namespace
}  // namespace ef
