// Surfel PLY: write / read round trip, header layout, and rejection of malformed files.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "io/ply_writer.h"
#include "test_support.h"

namespace ef {
namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}
void spit(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

// Interleaved positions/normals (as an array-of-structs pool would hold them), separate others.
struct Fixture {
  static constexpr int kN = 5;
  float pos[kN][3], nrm[kN][3], radius[kN], conf[kN], prob[kN];
  uint8_t rgb[kN][3], cls[kN];
  Fixture() {
    for (int i = 0; i < kN; ++i) {
      pos[i][0] = 0.5f * i;
      pos[i][1] = -1.25f + i;
      pos[i][2] = 3.0f + 0.125f * i;
      nrm[i][0] = 0;
      nrm[i][1] = (i % 2) ? 1.0f : 0.0f;
      nrm[i][2] = (i % 2) ? 0.0f : -1.0f;
      rgb[i][0] = static_cast<uint8_t>(10 * i);
      rgb[i][1] = static_cast<uint8_t>(255 - i);
      rgb[i][2] = static_cast<uint8_t>(128 + i);
      radius[i] = 0.01f * (i + 1);
      conf[i] = 2.5f * i;
      cls[i] = static_cast<uint8_t>(i * 3);
      prob[i] = 0.2f * i;
    }
  }
  SurfelCloudView view() const {
    SurfelCloudView v;
    v.count = kN;
    v.x = {&pos[0][0], sizeof pos[0]};
    v.y = {&pos[0][1], sizeof pos[0]};
    v.z = {&pos[0][2], sizeof pos[0]};
    v.nx = {&nrm[0][0], sizeof nrm[0]};
    v.ny = {&nrm[0][1], sizeof nrm[0]};
    v.nz = {&nrm[0][2], sizeof nrm[0]};
    v.red = {&rgb[0][0], 3};
    v.green = {&rgb[0][1], 3};
    v.blue = {&rgb[0][2], 3};
    v.radius = radius;
    v.confidence = conf;
    v.class_id = cls;
    v.class_prob = prob;
    return v;
  }
};

const char* kExpectedHeader =
    "ply\nformat binary_little_endian 1.0\ncomment EdgeFusion surfel map\ncomment run 7\nelement vertex 5\n"
    "property float x\nproperty float y\nproperty float z\n"
    "property float nx\nproperty float ny\nproperty float nz\n"
    "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    "property float radius\nproperty float confidence\n"
    "property uchar class_id\nproperty float class_prob\nend_header\n";

TEST(OutputsPly, RoundTripIsExact) {
  const Fixture f;
  const std::string path = (test::scratch_dir("ply_rt") / "map.ply").string();
  ASSERT_TRUE(write_surfel_ply(path, f.view(), "run 7").ok());
  const std::string bytes = slurp(path);
  const std::string header = kExpectedHeader;
  ASSERT_EQ(bytes.substr(0, header.size()), header);
  ASSERT_EQ(bytes.size(), header.size() + 5 * 40);
  // First record, byte by byte: x = 0.0f, y = -1.25f = 0xBFA00000 little-endian.
  const unsigned char* rec = reinterpret_cast<const unsigned char*>(bytes.data() + header.size());
  EXPECT_EQ(rec[4], 0x00);
  EXPECT_EQ(rec[5], 0x00);
  EXPECT_EQ(rec[6], 0xA0);
  EXPECT_EQ(rec[7], 0xBF);
  EXPECT_EQ(rec[24], 0);    // red of surfel 0
  EXPECT_EQ(rec[25], 255);  // green
  EXPECT_EQ(rec[26], 128);  // blue
  EXPECT_EQ(rec[35], 0);    // class_id

  auto c = read_surfel_ply(path);
  ASSERT_TRUE(c.ok()) << to_string(c.error());
  ASSERT_EQ(c->size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(c->x[i], f.pos[i][0]);
    EXPECT_EQ(c->y[i], f.pos[i][1]);
    EXPECT_EQ(c->z[i], f.pos[i][2]);
    EXPECT_EQ(c->nx[i], f.nrm[i][0]);
    EXPECT_EQ(c->ny[i], f.nrm[i][1]);
    EXPECT_EQ(c->nz[i], f.nrm[i][2]);
    EXPECT_EQ(c->red[i], f.rgb[i][0]);
    EXPECT_EQ(c->green[i], f.rgb[i][1]);
    EXPECT_EQ(c->blue[i], f.rgb[i][2]);
    EXPECT_EQ(c->radius[i], f.radius[i]);
    EXPECT_EQ(c->confidence[i], f.conf[i]);
    EXPECT_EQ(c->class_id[i], f.cls[i]);
    EXPECT_EQ(c->class_prob[i], f.prob[i]);
  }
  // Writing the read-back cloud reproduces the file byte for byte.
  const std::string path2 = (test::scratch_dir("ply_rt2") / "map.ply").string();
  ASSERT_TRUE(write_surfel_ply(path2, c->view(), "run 7").ok());
  EXPECT_EQ(slurp(path2), bytes);
}

// Without a class_id column (a map without labels) neither class property is written: 35-byte
// records, read back as zeros with has_classes false, and rewritten byte for byte (issue 33, rough
// edge 3: --no-labels wrote class columns of zeros).
TEST(OutputsPly, NoClassColumnsWithoutClasses) {
  const Fixture f;
  SurfelCloudView v = f.view();
  v.class_id = {};
  v.class_prob = {};
  const std::string path = (test::scratch_dir("ply_noclass") / "map.ply").string();
  ASSERT_TRUE(write_surfel_ply(path, v, "run 7").ok());
  const std::string bytes = slurp(path);
  std::string header = kExpectedHeader;
  const auto cls = header.find("property uchar class_id\n");
  header.erase(cls, header.find("end_header") - cls);
  ASSERT_EQ(bytes.substr(0, header.size()), header);
  EXPECT_EQ(bytes.size(), header.size() + 5 * kPlySurfelRecordBytesWithoutClasses);
  auto c = read_surfel_ply(path);
  ASSERT_TRUE(c.ok()) << to_string(c.error());
  EXPECT_FALSE(c->has_classes);
  ASSERT_EQ(c->size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(c->confidence[i], f.conf[i]);
    EXPECT_EQ(c->class_id[i], 0);
  }
  const std::string path2 = (test::scratch_dir("ply_noclass2") / "map.ply").string();
  ASSERT_TRUE(write_surfel_ply(path2, c->view(), "run 7").ok());
  EXPECT_EQ(slurp(path2), bytes);
  // A file with classes reads back with them.
  ASSERT_TRUE(write_surfel_ply(path2, f.view()).ok());
  auto with = read_surfel_ply(path2);
  ASSERT_TRUE(with.ok());
  EXPECT_TRUE(with->has_classes);
}

TEST(OutputsPly, LargeCloudSpansChunksAndEmptyCloud) {
  const int n = 5000;  // > one 64 KiB chunk of 40-byte records
  std::vector<float> x(n), y(n), z(n);
  for (int i = 0; i < n; ++i) {
    x[i] = static_cast<float>(i);
    y[i] = static_cast<float>(-i);
    z[i] = 1.0f / (i + 1);
  }
  SurfelCloudView v;
  v.count = n;
  v.x = x.data();
  v.y = y.data();
  v.z = z.data();
  const std::string path = (test::scratch_dir("ply_big") / "big.ply").string();
  ASSERT_TRUE(write_surfel_ply(path, v).ok());
  auto c = read_surfel_ply(path);
  ASSERT_TRUE(c.ok()) << to_string(c.error());
  ASSERT_EQ(c->size(), static_cast<std::size_t>(n));
  EXPECT_EQ(c->x[4999], 4999.0f);
  EXPECT_EQ(c->z[1637], 1.0f / 1638);
  EXPECT_EQ(c->class_prob[4000], 0.0f);  // null column written as zeros
  EXPECT_EQ(c->red[123], 0);

  SurfelCloudView empty;
  ASSERT_TRUE(write_surfel_ply(path, empty).ok());
  auto e = read_surfel_ply(path);
  ASSERT_TRUE(e.ok()) << to_string(e.error());
  EXPECT_EQ(e->size(), 0u);
}

TEST(OutputsPly, WriterRejectsMissingPositionsAndBadFolder) {
  SurfelCloudView v;
  v.count = 3;
  EXPECT_FALSE(write_surfel_ply((test::scratch_dir("ply_nox") / "a.ply").string(), v).ok());
  Fixture f;
  auto s = write_surfel_ply("/nonexistent-dir/edgefusion/a.ply", f.view());
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("/nonexistent-dir/edgefusion/a.ply"), std::string::npos);
}

class PlyMalformed : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::scratch_dir("ply_bad");
    good_ = (dir_ / "good.ply").string();
    ASSERT_TRUE(write_surfel_ply(good_, Fixture().view()).ok());
    bytes_ = slurp(good_);
  }
  // Writes `content` and expects read_surfel_ply to fail with `fault` in the message.
  void expect_rejected(const std::string& content, const std::string& fault) {
    const std::string p = (dir_ / "bad.ply").string();
    spit(p, content);
    auto c = read_surfel_ply(p);
    ASSERT_FALSE(c.ok()) << "accepted; expected: " << fault;
    EXPECT_NE(c.error().message.find(p), std::string::npos) << c.error().message;
    EXPECT_NE(c.error().message.find(fault), std::string::npos) << c.error().message;
  }
  std::string replace(const std::string& from, const std::string& to) {
    std::string s = bytes_;
    const auto at = s.find(from);
    EXPECT_NE(at, std::string::npos);
    return s.replace(at, from.size(), to);
  }
  std::filesystem::path dir_;
  std::string good_, bytes_;
};

TEST_F(PlyMalformed, Truncated) { expect_rejected(bytes_.substr(0, bytes_.size() - 1), "truncated"); }
TEST_F(PlyMalformed, HugeVertexCount) {
  expect_rejected(replace("element vertex 5", "element vertex 9223372036854775807"), "truncated");
}
TEST_F(PlyMalformed, TrailingBytes) { expect_rejected(bytes_ + "xy", "2 trailing bytes"); }
TEST_F(PlyMalformed, NotPly) { expect_rejected("solid cube\n", "not a PLY file"); }
TEST_F(PlyMalformed, AsciiFormat) { expect_rejected(replace("binary_little_endian", "ascii"), "format 'ascii'"); }
TEST_F(PlyMalformed, BigEndian) {
  expect_rejected(replace("binary_little_endian", "binary_big_endian"), "not supported");
}
TEST_F(PlyMalformed, NoEndHeader) { expect_rejected(replace("end_header", "end_heade"), "unexpected header line"); }
TEST_F(PlyMalformed, MissingX) { expect_rejected(replace("property float x\n", "property float w\n"), "lacks float x"); }
TEST_F(PlyMalformed, WrongType) {
  expect_rejected(replace("property uchar class_id", "property short class_id"), "expected 'uchar'");
}
TEST_F(PlyMalformed, UnknownType) { expect_rejected(replace("property float radius", "property half radius"), "unknown property type 'half'"); }
TEST_F(PlyMalformed, FacesNotSupported) {
  expect_rejected(replace("end_header", "element face 2\nproperty list uchar int vertex_indices\nend_header"),
                  "element 'face' with 2 entries");
}
TEST_F(PlyMalformed, MissingFile) {
  auto c = read_surfel_ply((dir_ / "none.ply").string());
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().code, ErrorCode::kNotFound);
}

// A file from another tool: extra properties are skipped, missing optional ones read as zero.
TEST(OutputsPly, ReadsForeignLayoutSkippingUnknownProperties) {
  std::string s =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty double time\nproperty float x\n"
      "property float y\nproperty float z\nproperty uchar red\nend_header\n";
  auto put_f = [&](float v) { s.append(reinterpret_cast<const char*>(&v), 4); };  // host is little-endian here
  for (int i = 0; i < 2; ++i) {
    const double t = 42.0;
    s.append(reinterpret_cast<const char*>(&t), 8);
    put_f(1.0f + i);
    put_f(2.0f);
    put_f(3.0f);
    s.push_back(static_cast<char>(200 + i));
  }
  const std::string p = (test::scratch_dir("ply_foreign") / "f.ply").string();
  spit(p, s);
  auto c = read_surfel_ply(p);
  ASSERT_TRUE(c.ok()) << to_string(c.error());
  ASSERT_EQ(c->size(), 2u);
  EXPECT_EQ(c->x[1], 2.0f);
  EXPECT_EQ(c->z[0], 3.0f);
  EXPECT_EQ(c->red[1], 201);
  EXPECT_EQ(c->nx[0], 0.0f);
}

}  // namespace
}  // namespace ef
