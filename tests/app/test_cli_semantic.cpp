// `edgefusion run` with labels (SemanticFusion), in-process through run_cli(), with a tiny network
// written to a scratch folder: the schedule of CNN frames and rendered images, the rendering's
// agreement with the CNN on the first frame, map.ply's class columns, and option errors.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "app/cli_test_util.h"
#include "core/frame.h"
#include "firmware_app/cli.h"
#include "io/image_codec.h"
#include "io/ply_writer.h"
#include "semantic/segmenter.h"
#include "semantic/semantic_test_util.h"
#include "sources/open_source.h"
#include "test_support.h"

namespace ef::app {
namespace {

namespace fs = std::filesystem;

fs::path tiny_model(const fs::path& dir) {
  const fs::path p = dir / "tiny-seg.efm";
  EXPECT_EQ(test::write_model_file(test::tiny_seg_net(24, 32), p), "");
  return p;
}

// The counter `name` of stats.json (-1 when absent).
double stats_counter(const std::string& stats, const std::string& name) {
  const auto at = stats.find("\"" + name + "\":");
  if (at == std::string::npos) return -1;
  return std::stod(stats.substr(at + name.size() + 3));
}

TEST(CliSemantic, RunFusesLabelsRendersThemAndWritesClassColumns) {
  const auto dir = test::scratch_dir("cli-semantic");
  const fs::path model = tiny_model(dir);
  const std::string uri = "synthetic:bedroom?frames=10&size=160x120";
  auto r = cli({"run", "--source", uri, "--resolution", "160x120", "--model", model.string(), "--label-every", "3",
                "--labels-out", (dir / "labels").string(), "--labels-out-every", "4", "--out", (dir / "run").string(),
                "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;

  // Label images for frames 0, 4 and 8, named as the source names its frames.
  auto source = open_source(uri);
  ASSERT_TRUE(source.ok());
  Frame f;
  std::vector<std::string> stems;
  while (*(*source)->next(f)) stems.push_back(f.name.empty() ? "" : f.name);
  ASSERT_EQ(stems.size(), 10u);
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir / "labels")) {
    (void)e;
    ++files;
  }
  EXPECT_EQ(files, 3);
  for (int i : {0, 4, 8}) {
    const fs::path png = dir / "labels" / (stems[std::size_t(i)] + ".png");
    ASSERT_TRUE(fs::exists(png)) << png;
  }

  // Frame 0: the map has exactly one observation, the CNN's of frame 0, so its rendering is the
  // CNN's own prediction wherever the map is seen (the cost table rounds only near-ties).
  auto seg = semantic::Segmenter::create(model.string());
  ASSERT_TRUE(seg.ok());
  auto again = open_source(uri);
  ASSERT_TRUE(again.ok());
  ASSERT_TRUE(*(*again)->next(f));
  Image<uint8_t> cnn(160, 120);
  ASSERT_TRUE((*seg)->segment(f, cnn.view()).ok());
  Image<uint8_t> rendered;
  ASSERT_TRUE(read_png_u8((dir / "labels" / (stems[0] + ".png")).string(), rendered).ok());
  ASSERT_EQ(rendered.width(), 160);
  ASSERT_EQ(rendered.height(), 120);
  int same = 0;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) same += rendered(x, y) == cnn(x, y);
  EXPECT_GT(same, 160 * 120 * 97 / 100) << same;

  // Statistics: the CNN ran on frames 0, 3, 4, 6, 8, 9 (fusion every 3rd, renderings every 4th).
  const std::string stats = read_file(dir / "run" / "stats.json");
  EXPECT_EQ(stats_counter(stats, "cnn_frames"), 6) << stats;
  EXPECT_EQ(stats_counter(stats, "label_images_written"), 3) << stats;
  EXPECT_GT(stats_counter(stats, "surfel_label_updates"), 1000) << stats;
  EXPECT_EQ(stats_counter(stats, "crf_runs"), 0) << stats;
  for (const char* stage : {"\"segment\"", "\"label_fuse\"", "\"label_render\""})
    EXPECT_NE(stats.find(stage), std::string::npos) << stage;

  // map.ply: observed surfels carry a class with a probability above uniform; never-observed ones
  // class 0 at 1/14.
  auto map = read_surfel_ply((dir / "run" / "map.ply").string());
  ASSERT_TRUE(map.ok()) << to_string(map.error());
  ASSERT_GT(map->size(), 1000u);
  std::size_t observed = 0;
  for (std::size_t i = 0; i < map->size(); ++i) {
    ASSERT_LE(map->class_id[i], 13);
    ASSERT_GT(map->class_prob[i], 0.0f);
    ASSERT_LE(map->class_prob[i], 1.0f);
    if (map->class_prob[i] > 1.0f / 14.0f + 1e-4f) ++observed;
    else ASSERT_NEAR(map->class_prob[i], 1.0f / 14.0f, 1e-4f);
  }
  EXPECT_GT(observed, map->size() / 2) << observed << " of " << map->size();

  // The same run without labels: no class columns (all zero) and no CNN.
  r = cli({"run", "--source", uri, "--resolution", "160x120", "--no-labels", "--frames", "2", "--out",
           (dir / "geometry").string(), "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("labels off"), std::string::npos) << r.err;
  auto plain = read_surfel_ply((dir / "geometry" / "map.ply").string());
  ASSERT_TRUE(plain.ok());
  for (std::size_t i = 0; i < plain->size(); i += 97) ASSERT_EQ(plain->class_prob[i], 0.0f);
  EXPECT_EQ(stats_counter(read_file(dir / "geometry" / "stats.json"), "cnn_frames"), -1);
}

// The dense CRF runs every M frames and once more at the end; it changes the map's labels.
TEST(CliSemantic, CrfEveryMFramesAndAtTheEnd) {
  const auto dir = test::scratch_dir("cli-semantic-crf");
  const fs::path model = tiny_model(dir);
  const std::string uri = "synthetic:bedroom?frames=10&size=160x120";
  auto r = cli({"run", "--source", uri, "--resolution", "160x120", "--model", model.string(), "--label-every", "2",
           "--crf-every", "4", "--crf-final", "--crf-iterations", "3", "--surfel-capacity", "100000", "--out",
           (dir / "crf").string(), "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string stats = read_file(dir / "crf" / "stats.json");
  EXPECT_EQ(stats_counter(stats, "crf_runs"), 3) << stats;  // frames 4 and 8, then the end (frame 10)
  EXPECT_EQ(stats_counter(stats, "crf_surfels_left_out"), 0) << stats;
  EXPECT_NE(r.err.find("dense CRF at frame 10"), std::string::npos) << r.err;

  r = cli({"run", "--source", uri, "--resolution", "160x120", "--model", model.string(), "--label-every", "2",
           "--surfel-capacity", "100000", "--out", (dir / "nocrf").string(), "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  auto with = read_surfel_ply((dir / "crf" / "map.ply").string());
  auto without = read_surfel_ply((dir / "nocrf" / "map.ply").string());
  ASSERT_TRUE(with.ok());
  ASSERT_TRUE(without.ok());
  ASSERT_EQ(with->size(), without->size());  // the CRF touches labels only, never geometry
  std::size_t changed = 0;
  for (std::size_t i = 0; i < with->size(); ++i) {
    ASSERT_EQ(with->x[i], without->x[i]);
    changed += with->class_id[i] != without->class_id[i] || with->class_prob[i] != without->class_prob[i];
  }
  EXPECT_GT(changed, with->size() / 10) << changed << " of " << with->size();
}

TEST(CliSemantic, OptionErrorsNameTheOptionOrKey) {
  const auto dir = test::scratch_dir("cli-semantic-errors");
  auto r = cli({"run", "--source", "synthetic:?frames=2", "--no-labels", "--labels-out", (dir / "l").string(), "--out",
                (dir / "o").string()});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--labels-out"), std::string::npos) << r.err;

  r = cli({"run", "--source", "synthetic:?frames=2", "--model", (dir / "absent.efm").string(), "--out",
           (dir / "o").string()});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("absent.efm"), std::string::npos) << r.err;

  r = cli({"run", "--source", "synthetic:?frames=2", "--label-every", "0", "--out", (dir / "o").string()});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--label-every"), std::string::npos) << r.err;

  const auto cfg = dir / "run.yaml";
  std::ofstream(cfg) << "labels: maybe\n";
  r = cli({"run", "--config", cfg.string(), "--out", (dir / "o").string()});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("'labels'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("maybe"), std::string::npos) << r.err;

  std::ofstream(cfg) << "crf_iterations: 1000\n";
  r = cli({"run", "--config", cfg.string(), "--out", (dir / "o").string()});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("crf_iterations"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace ef::app
