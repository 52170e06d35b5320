// The snapshot container of map checkpoints (io/snapshot_file.h): sections round-trip, and every
// damage (a cut at any byte, a flipped bit in any section, another version) is named, never read.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "io/snapshot_file.h"
#include "io_test_util.h"
#include "test_support.h"

namespace ef {
namespace {

namespace fs = std::filesystem;

constexpr char kA[4] = {'A', 'A', 'A', 'A'}, kB[4] = {'B', 'B', 'B', 'B'}, kC[4] = {'C', 'C', 'C', 'C'};

// Three sections: 5 bytes, 1000 floats in two parts, and an empty one.
std::string write_sample(const fs::path& dir, std::vector<float>& floats) {
  floats.resize(1000);
  for (std::size_t i = 0; i < floats.size(); ++i) floats[i] = 0.5f * float(i) - 7.0f;
  const std::string path = (dir / "s.efs").string();
  SnapshotWriter w;
  EXPECT_TRUE(w.open(path).ok());
  EXPECT_TRUE(w.section(kA, "hello", 5).ok());
  const SnapshotWriter::Part parts[2] = {{floats.data(), 400 * sizeof(float)}, {floats.data() + 400, 600 * sizeof(float)}};
  EXPECT_TRUE(w.section(kB, parts, 2).ok());
  EXPECT_TRUE(w.section(kC, static_cast<const void*>(nullptr), 0).ok());
  EXPECT_FALSE(fs::exists(path));  // until committed, only the .partial exists
  EXPECT_TRUE(w.commit().ok());
  return path;
}

TEST(SnapshotFile, SectionsRoundTrip) {
  const auto dir = test::scratch_dir("snapshot-rt");
  std::vector<float> floats;
  const std::string path = write_sample(dir, floats);
  SnapshotReader r;
  ASSERT_TRUE(r.open(path).ok());
  EXPECT_TRUE(r.has(kA));
  EXPECT_EQ(r.size(kA), 5u);
  EXPECT_EQ(r.size(kB), 4000u);
  EXPECT_TRUE(r.has(kC));
  EXPECT_EQ(r.size(kC), 0u);
  char hello[5];
  ASSERT_TRUE(r.read(kA, hello, 5).ok());
  EXPECT_EQ(std::string(hello, 5), "hello");
  std::vector<float> back(600);
  ASSERT_TRUE(r.read(kB, back.data(), 600 * sizeof(float), 400 * sizeof(float)).ok());  // from an offset
  EXPECT_EQ(std::memcmp(back.data(), floats.data() + 400, 600 * sizeof(float)), 0);
  // Past the end of a section, and a section that is not there: errors naming them.
  auto s = r.read(kA, hello, 5, 1);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("section 'AAAA' has 5 bytes"), std::string::npos) << s.error().message;
  constexpr char kNone[4] = {'N', 'O', 'N', 'E'};
  EXPECT_FALSE(r.has(kNone));
  EXPECT_FALSE(r.read(kNone, hello, 1).ok());
}

TEST(SnapshotFile, ACommitKeepsThePreviousSnapshot) {
  const auto dir = test::scratch_dir("snapshot-prev");
  const std::string path = (dir / "s.efs").string(), prev = (dir / "s.prev.efs").string();
  for (const char* text : {"first", "second"}) {
    SnapshotWriter w;
    ASSERT_TRUE(w.open(path).ok());
    ASSERT_TRUE(w.section(kA, text, std::strlen(text)).ok());
    ASSERT_TRUE(w.commit(prev).ok());
  }
  SnapshotReader now, before;
  ASSERT_TRUE(now.open(path).ok());
  ASSERT_TRUE(before.open(prev).ok());
  EXPECT_EQ(now.size(kA), 6u);     // "second"
  EXPECT_EQ(before.size(kA), 5u);  // "first"
}

TEST(SnapshotFile, EveryCutIsAnErrorAndNeverARead) {
  const auto dir = test::scratch_dir("snapshot-cut");
  std::vector<float> floats;
  const std::string bytes = test::read_bytes(write_sample(dir, floats));
  const std::string path = (dir / "cut.efs").string();
  for (std::size_t cut = 0; cut < bytes.size(); cut += (cut < 64 || cut + 64 > bytes.size()) ? 1 : 97) {
    test::write_bytes(path, bytes.substr(0, cut));
    SnapshotReader r;
    auto s = r.open(path);
    ASSERT_FALSE(s.ok()) << cut;
    EXPECT_EQ(s.error().code, ErrorCode::kCorruptData) << cut;
    EXPECT_NE(s.error().message.find(path), std::string::npos) << s.error().message;
  }
}

TEST(SnapshotFile, AFlippedBitInAnySectionIsNamed) {
  const auto dir = test::scratch_dir("snapshot-flip");
  std::vector<float> floats;
  const std::string bytes = test::read_bytes(write_sample(dir, floats));
  const std::string path = (dir / "flip.efs").string();
  // Section AAAA's payload at 16 + 16; BBBB's at 16 + 16 + 8 (5 bytes padded) + 16.
  struct Case {
    std::size_t at;
    const char* says;
  };
  for (const Case& c : {Case{0, "bad magic"}, Case{8, "version"}, Case{33, "section 'AAAA': CRC-32 mismatch"},
                        Case{16 + 16 + 8 + 16 + 2000, "section 'BBBB': CRC-32 mismatch"},
                        Case{bytes.size() - 8, "CRC-32"}}) {
    std::string damaged = bytes;
    damaged[c.at] = static_cast<char>(damaged[c.at] ^ 0x10);
    test::write_bytes(path, damaged);
    SnapshotReader r;
    auto s = r.open(path);
    ASSERT_FALSE(s.ok()) << c.at;
    EXPECT_NE(s.error().message.find(c.says), std::string::npos) << c.at << ": " << s.error().message;
  }
}

}  // namespace
}  // namespace ef
