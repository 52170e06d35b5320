// `edgefusion run` with labels (SemanticFusion), in-process through run_cli(), with a tiny network
// written to a scratch folder: the schedule of CNN frames and rendered images, the rendering's
// agreement with the CNN on the first frame, map.ply's class columns, and option errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "app/cli_test_util.h"
#include "core/frame.h"
#include "firmware_app/cli.h"
#include "pipeline/final_labels.h"
#include "pipeline/mapping_stage.h"
#include "io/image_codec.h"
#include "io/ply_writer.h"
#include "semantic/segmenter.h"
#include "semantic/semantic_test_util.h"
#include "sources/open_source.h"
#include "test_support.h"

namespace ef::app {

using namespace ef::pipeline;
namespace {

namespace fs = std::filesystem;

// The counter `name` of stats.json (-1 when absent).
double stats_counter(const std::string& stats, const std::string& name) {
  const auto at = stats.find("\"" + name + "\":");
  if (at == std::string::npos) return -1;
  return std::stod(stats.substr(at + name.size() + 3));
}

TEST(CliSemantic, RunFusesLabelsRendersThemAndWritesClassColumns) {
  const auto dir = test::scratch_dir("cli-semantic");
  const fs::path model = test::write_tiny_seg_model(dir);
  const std::string uri = "synthetic:bedroom?frames=10&size=160x120";
  auto r = cli({"run", "--source", uri, "--resolution", "160x120", "--model", model.string(), "--label-every", "3",
                "--labels-out", (dir / "labels").string(), "--labels-out-every", "4", "--out", (dir / "run").string(),
                "--deterministic", "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  // The label folder is among the paths printed at the end (issue 33, rough edge 11).
  EXPECT_NE(r.out.find("labels: " + (dir / "labels").string() + " (3 images, every 4 frames;"), std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("surfel pool full"), std::string::npos) << r.out;

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

  // Statistics: the CNN ran on frames 0, 3, 4, 6, 8, 9 (fusion every 3rd, renderings every 4th);
  // --deterministic makes mapping wait for each result, so none is skipped on a loaded machine.
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

// --labels-final-out: a second reading of the recording renders the finished map at each frame's
// estimated pose. At the run's last frame the finished map is the map that frame saw, so the two
// renderings must agree pixel for pixel; a pose matched to the wrong frame would not.
TEST(CliSemantic, FinalLabelsRenderTheFinishedMapAtEachFramesPose) {
  const auto dir = test::scratch_dir("cli-semantic-final");
  const fs::path model = test::write_tiny_seg_model(dir);
  const std::string uri = "synthetic:bedroom?frames=12&size=160x120";
  // --frames 9: the second reading stops where the run stopped too (frames 0, 4 and 8 are due).
  auto r = cli({"run", "--source", uri, "--resolution", "160x120", "--model", model.string(), "--label-every", "2",
                "--frames", "9", "--labels-out", (dir / "online").string(), "--labels-out-every", "4",
                "--labels-final-out", (dir / "final").string(), "--out", (dir / "run").string(), "--deterministic",
                "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("final labels: 3 images"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("0 frames not mapped"), std::string::npos) << r.out;

  auto source = open_source(uri);
  ASSERT_TRUE(source.ok());
  Frame f;
  std::vector<std::string> stems;
  while (*(*source)->next(f)) stems.push_back(f.name);
  ASSERT_EQ(stems.size(), 12u);
  std::vector<std::string> written;
  for (const auto& e : fs::directory_iterator(dir / "final")) written.push_back(e.path().stem().string());
  std::sort(written.begin(), written.end());
  EXPECT_EQ(written, (std::vector<std::string>{stems[0], stems[4], stems[8]}));

  auto read = [&](const char* folder, int frame) {
    Image<uint8_t> img;
    EXPECT_TRUE(read_png_u8((dir / folder / (stems[std::size_t(frame)] + ".png")).string(), img).ok());
    return img;
  };
  int differ_last = 0, differ_first = 0;
  const Image<uint8_t> online8 = read("online", 8), final8 = read("final", 8);
  const Image<uint8_t> online0 = read("online", 0), final0 = read("final", 0);
  ASSERT_EQ(final8.width(), 160);
  ASSERT_EQ(final8.height(), 120);
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) {
      differ_last += online8(x, y) != final8(x, y);
      differ_first += online0(x, y) != final0(x, y);
    }
  EXPECT_EQ(differ_last, 0);
  // Frame 0's online rendering saw one observation; the finished map has five (frames 0..8, every 2nd).
  EXPECT_GT(differ_first, 0);

  // It needs labels, and names the option when they are off.
  r = cli({"run", "--source", uri, "--no-labels", "--labels-final-out", (dir / "x").string(), "--out",
           (dir / "o").string(), "--quiet"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--labels-final-out"), std::string::npos) << r.err;
}

// The pass's frame matching on a trajectory it did not write: a frame without a line is skipped and
// counted, a frame after a "# lost" line gets the CNN's labels alone.
TEST(FinalLabels, MatchesFramesToTrajectoryLinesByTimestamp) {
  const auto dir = test::scratch_dir("final-labels-match");
  const fs::path model = test::write_tiny_seg_model(dir);
  RunConfig config;
  config.run.source = "synthetic:bedroom?frames=6&size=160x120";
  config.run.resolution.width = 160;
  config.run.resolution.height = 120;
  config.labels.model = model.string();
  config.mapping.pool.capacity = 100000;
  config.labels.out_every = 1;
  config.labels.final_out = (dir / "final").string();
  auto source = open_source(config.run.source);
  ASSERT_TRUE(source.ok());
  const Intrinsics working = (*source)->info().intrinsics.scaled_to(160, 120);
  StageStats stats;
  auto semantics = RunSemantics::create(semantics_options(config), working, stats);
  ASSERT_TRUE(semantics.ok()) << to_string(semantics.error());
  auto slam = slam::SurfelSlam::create(working, MappingStage::slam_options(config.mapping));
  ASSERT_TRUE(slam.ok());

  // Frames 0..5: no line for frame 2, frame 4 marked lost.
  std::vector<double> stamps;
  Frame f;
  while (*(*source)->next(f)) stamps.push_back(f.timestamp);
  ASSERT_EQ(stamps.size(), 6u);
  const fs::path trajectory = dir / "trajectory.txt";
  {
    std::ofstream out(trajectory);
    out << "# timestamp tx ty tz qx qy qz qw\n";
    for (std::size_t i = 0; i < stamps.size(); ++i) {
      if (i == 2) continue;
      char line[128];
      if (i == 4) {
        std::snprintf(line, sizeof line, "# lost %.6f too_few_points\n", stamps[i]);
        out << line;
      }
      std::snprintf(line, sizeof line, "%.6f 0 0 0 0 0 0 1\n", stamps[i]);
      out << line;
    }
  }
  auto replay = open_source(config.run.source);
  ASSERT_TRUE(replay.ok());
  auto counts = render_final_labels(config.run, config.labels, **replay, trajectory.string(), *slam, **semantics);
  ASSERT_TRUE(counts.ok()) << to_string(counts.error());
  EXPECT_EQ(counts->frames_read, 6);
  EXPECT_EQ(counts->images_written, 5);
  EXPECT_EQ(counts->not_mapped, 1);
  EXPECT_EQ(counts->from_cnn_only, 1);
  EXPECT_FALSE(counts->stopped);

  // A run stopped after frame 3 (its trajectory ends there): the reading stops after it instead of
  // reading the whole recording (issue 33, rough edge 1).
  {
    std::ofstream out(trajectory);
    out << "# timestamp tx ty tz qx qy qz qw\n";
    for (std::size_t i = 0; i <= 3; ++i) {
      char line[128];
      std::snprintf(line, sizeof line, "%.6f 0 0 0 0 0 0 1\n", stamps[i]);
      out << line;
    }
  }
  replay = open_source(config.run.source);
  ASSERT_TRUE(replay.ok());
  counts = render_final_labels(config.run, config.labels, **replay, trajectory.string(), *slam, **semantics);
  ASSERT_TRUE(counts.ok()) << to_string(counts.error());
  EXPECT_EQ(counts->frames_read, 4);
  EXPECT_EQ(counts->images_written, 4);
  EXPECT_EQ(counts->not_mapped, 0);
  // A stop request (a signal during the pass) ends it before the next frame; the images so far stay.
  replay = open_source(config.run.source);
  ASSERT_TRUE(replay.ok());
  int asked = 0;
  counts = render_final_labels(config.run, config.labels, **replay, trajectory.string(), *slam, **semantics,
                               [&asked] { return ++asked > 2; });
  ASSERT_TRUE(counts.ok()) << to_string(counts.error());
  EXPECT_TRUE(counts->stopped);
  EXPECT_EQ(counts->frames_read, 2);
  EXPECT_EQ(counts->images_written, 2);
}

// The dense CRF runs every M frames and once more at the end; it changes the map's labels.
TEST(CliSemantic, CrfEveryMFramesAndAtTheEnd) {
  const auto dir = test::scratch_dir("cli-semantic-crf");
  const fs::path model = test::write_tiny_seg_model(dir);
  const std::string uri = "synthetic:bedroom?frames=10&size=160x120";
  const std::vector<std::string> crf = {"run", "--source", uri, "--resolution", "160x120", "--model", model.string(),
                                        "--label-every", "2", "--crf-every", "4", "--crf-final", "--crf-iterations",
                                        "3", "--surfel-capacity", "100000", "--deterministic", "--quiet"};
  // At the default crf.min_confidence (the stable threshold) ten frames leave most surfels out.
  auto args = crf;
  args.insert(args.end(), {"--out", (dir / "stable").string()});
  auto r = cli(args);
  ASSERT_EQ(r.code, 0) << r.err;
  std::string stats = read_file(dir / "stable" / "stats.json");
  EXPECT_EQ(stats_counter(stats, "crf_runs"), 3) << stats;
  EXPECT_GT(stats_counter(stats, "crf_surfels_unconfident"), 0) << stats;
  EXPECT_NE(r.err.find("below crf.min_confidence"), std::string::npos) << r.err;
  // Every surfel a node (crf.min_confidence 0, from a configuration file).
  {
    std::ofstream yaml(dir / "every.yaml");
    yaml << "crf:\n  min_confidence: 0\n";
  }
  args = crf;
  args.insert(args.end(), {"--config", (dir / "every.yaml").string(), "--out", (dir / "crf").string()});
  r = cli(args);
  ASSERT_EQ(r.code, 0) << r.err;
  stats = read_file(dir / "crf" / "stats.json");
  EXPECT_EQ(stats_counter(stats, "crf_runs"), 3) << stats;  // frames 4 and 8, then the end (frame 10)
  EXPECT_EQ(stats_counter(stats, "crf_surfels_left_out"), 0) << stats;
  EXPECT_EQ(stats_counter(stats, "crf_surfels_unconfident"), 0) << stats;
  EXPECT_NE(r.err.find("dense CRF at frame 10"), std::string::npos) << r.err;

  r = cli({"run", "--source", uri, "--resolution", "160x120", "--model", model.string(), "--label-every", "2",
           "--surfel-capacity", "100000", "--deterministic", "--out", (dir / "nocrf").string(), "--quiet"});
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

// A pool too small for the view: warned once when it fills, and the summary says how many surfels
// the full pool evicted and refused (issue 33, rough edge 4).
TEST(CliSemantic, AFullPoolIsWarnedAndSummarised) {
  const auto dir = test::scratch_dir("cli-pool-full");
  // 2,000 surfels: the first 160x120 frame offers up to 4,800 (every other pixel of every other row).
  auto r = cli({"run", "--source", "synthetic:?frames=4&size=160x120", "--resolution", "160x120", "--no-labels",
                "--surfel-capacity", "2000", "--out", (dir / "run").string(), "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("warning: the surfel pool is full (2000 surfels"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("warning: the surfel pool is full", r.err.find("warning: the surfel pool is full") + 1),
            std::string::npos)
      << "warned more than once: " << r.err;
  const auto line = r.out.find("surfel pool full (2000 surfels, mapping.surfel_capacity): ");
  ASSERT_NE(line, std::string::npos) << r.out;
  EXPECT_NE(r.out.find(" refused", line), std::string::npos) << r.out;
  // --no-labels: the map has no class properties (rough edge 3).
  auto map = read_surfel_ply((dir / "run" / "map.ply").string());
  ASSERT_TRUE(map.ok()) << to_string(map.error());
  EXPECT_FALSE(map->has_classes);
  EXPECT_GT(map->size(), 0u);
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
