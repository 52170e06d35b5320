// The YAML configuration (src/pipeline/run_config.h): sections and flat keys, errors that name the
// file, line, key and value, describe() as a file that reads back to the same configuration; the
// memory plan (src/pipeline/memory_plan.h) against what the classes really allocate and against the
// budget; `edgefusion plan`; the ARM64 example configuration of firmware_app/config/.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "app/cli_test_util.h"
#include "core/intrinsics.h"
#include "firmware_app/args.h"
#include "pipeline/final_labels.h"
#include "pipeline/memory_plan.h"
#include "pipeline/model_paths.h"
#include "firmware_app/config_file.h"
#include "pipeline/run_pipeline.h"
#include "sources/open_source.h"
#include "core/stage_stats.h"
#include "pipeline/run_semantics.h"
#include "semantic/dense_crf.h"
#include "semantic/segmenter.h"
#include "slam/surfel_fusion.h"
#include "slam/surfel_slam.h"
#include "test_support.h"

namespace ef::app {

using namespace ef::pipeline;
namespace {

namespace fs = std::filesystem;

const char* const kExampleConfig = EF_SOURCE_DIR "/firmware_app/config/edgefusion-arm64.yaml";

Result<RunConfig> read_text(const std::string& text) {
  RunConfig c;
  EF_RETURN_IF_ERROR(apply_config_text(text, "test.yaml", c));
  return c;
}

// Every field of two configurations, compared one by one (names in the failure message).
void expect_same(const RunConfig& a, const RunConfig& b) {
  EXPECT_EQ(a.source, b.source);
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.max_frames, b.max_frames);
  EXPECT_EQ(a.out_dir, b.out_dir);
  EXPECT_EQ(a.progress, b.progress);
  EXPECT_EQ(a.write_map, b.write_map);
  EXPECT_EQ(a.realtime, b.realtime);
  EXPECT_EQ(a.surfel_capacity, b.surfel_capacity);
  EXPECT_EQ(a.icp_weight, b.icp_weight);
  EXPECT_EQ(a.rgb_weight, b.rgb_weight);
  EXPECT_EQ(a.rgb_boost_condition, b.rgb_boost_condition);
  EXPECT_EQ(a.rgb_boost_max, b.rgb_boost_max);
  EXPECT_EQ(a.depth_cutoff_m, b.depth_cutoff_m);
  EXPECT_EQ(a.index_map_scale, b.index_map_scale);
  EXPECT_EQ(a.associate_at_tracked_pose, b.associate_at_tracked_pose);
  EXPECT_EQ(a.constant_velocity_guess, b.constant_velocity_guess);
  EXPECT_EQ(a.labels, b.labels);
  EXPECT_EQ(a.model, b.model);
  EXPECT_EQ(a.label_every, b.label_every);
  EXPECT_EQ(a.labels_out, b.labels_out);
  EXPECT_EQ(a.labels_out_every, b.labels_out_every);
  EXPECT_EQ(a.labels_final_out, b.labels_final_out);
  EXPECT_EQ(a.label_visibility, b.label_visibility);
  EXPECT_EQ(a.crf_every, b.crf_every);
  EXPECT_EQ(a.crf_final, b.crf_final);
  EXPECT_EQ(a.crf_iterations, b.crf_iterations);
  EXPECT_EQ(a.memory_budget_mb, b.memory_budget_mb);
  EXPECT_EQ(a.threads, b.threads);
  EXPECT_EQ(a.prepared_slots, b.prepared_slots);
  EXPECT_EQ(a.capture_slots, b.capture_slots);
  EXPECT_EQ(a.front_cpu, b.front_cpu);
  EXPECT_EQ(a.cnn_cpu, b.cnn_cpu);
  EXPECT_EQ(a.mapping_cpu, b.mapping_cpu);
  EXPECT_EQ(a.capture_cpu, b.capture_cpu);
  EXPECT_EQ(a.gpio.led.chip, b.gpio.led.chip);
  EXPECT_EQ(a.gpio.led.offset, b.gpio.led.offset);
  EXPECT_EQ(a.gpio.led.active_low, b.gpio.led.active_low);
  EXPECT_EQ(a.gpio.button.chip, b.gpio.button.chip);
  EXPECT_EQ(a.gpio.button.offset, b.gpio.button.offset);
  EXPECT_EQ(a.gpio.button.active_low, b.gpio.button.active_low);
  EXPECT_EQ(a.gpio.debounce_ms, b.gpio.debounce_ms);
  EXPECT_EQ(a.gpio.optional, b.gpio.optional);
}

TEST(ConfigYaml, GpioSectionAndItsErrors) {
  auto c = read_text(
      "gpio:\n"
      "  led_chip: gpiochip0\n"
      "  led_line: 17\n"
      "  button_chip: /dev/gpiochip1\n"
      "  button_line: 4\n"
      "  button_active_low: false\n"
      "  debounce_ms: 50\n"
      "  optional: true\n");
  ASSERT_TRUE(c.ok()) << to_string(c.error());
  EXPECT_EQ(c->gpio.led.chip, "gpiochip0");
  EXPECT_EQ(c->gpio.led.offset, 17u);
  EXPECT_FALSE(c->gpio.led.active_low);
  EXPECT_EQ(c->gpio.button.chip, "/dev/gpiochip1");
  EXPECT_EQ(c->gpio.button.offset, 4u);
  EXPECT_FALSE(c->gpio.button.active_low);
  EXPECT_EQ(c->gpio.debounce_ms, 50);
  EXPECT_TRUE(c->gpio.optional);
  RunConfig defaults;
  EXPECT_TRUE(defaults.gpio.led.chip.empty());
  EXPECT_TRUE(defaults.gpio.button.active_low);  // a push button to ground

  auto bad = read_text("gpio:\n  led_line: 5000\n");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(to_string(bad.error()).find("gpio.led_line"), std::string::npos) << to_string(bad.error());
  EXPECT_NE(to_string(bad.error()).find("5000"), std::string::npos) << to_string(bad.error());
}

TEST(ConfigYaml, SectionsSetTheOptions) {
  auto c = read_text(
      "source: synthetic:\n"
      "resolution: 320x240\n"
      "mapping: {surfel_capacity: 500000, icp_weight: 5, rgb_weight: 0.5, depth_cutoff_m: 4.5, index_map_scale: 2,\n"
      "          associate_at_tracked_pose: false}\n"
      "labels: {enabled: true, model: net.efm, every: 5, out: lab, out_every: 3, visibility: false}\n"
      "crf:\n"
      "  every: 100\n"
      "  final: true\n"
      "  iterations: 7\n"
      "memory: {budget_mb: 512}\n");
  ASSERT_TRUE(c.ok()) << to_string(c.error());
  EXPECT_EQ(c->source, "synthetic:");
  EXPECT_EQ(c->surfel_capacity, 500000);
  EXPECT_EQ(c->icp_weight, 5.0);
  EXPECT_EQ(c->rgb_weight, 0.5);
  EXPECT_EQ(c->depth_cutoff_m, 4.5f);
  EXPECT_EQ(c->index_map_scale, 2);
  EXPECT_FALSE(c->associate_at_tracked_pose);
  EXPECT_TRUE(c->labels);
  EXPECT_EQ(c->model, "net.efm");
  EXPECT_EQ(c->label_every, 5);
  EXPECT_EQ(c->labels_out, "lab");
  EXPECT_EQ(c->labels_out_every, 3);
  EXPECT_FALSE(c->label_visibility);
  EXPECT_EQ(c->crf_every, 100);
  EXPECT_TRUE(c->crf_final);
  EXPECT_EQ(c->crf_iterations, 7);
  EXPECT_EQ(c->memory_budget_mb, 512);
}

TEST(ConfigYaml, FlatKeysStillWork) {
  auto c = read_text(
      "# flat\nsource: synthetic:?frames=6\nresolution: 160x120\nframes: 4\nout: o\nprogress: off\nmap: no\n"
      "surfel_capacity: 1234\nicp_weight: 1\nrgb_weight: 2\ndepth_cutoff_m: 3\nlabels: false\nmodel: m.efm\n"
      "label_every: 2\nlabels_out: l\nlabels_out_every: 4\nlabel_visibility: false\ncrf_every: 9\ncrf_final: yes\n"
      "crf_iterations: 3\nmemory_budget_mb: 99\n");
  ASSERT_TRUE(c.ok()) << to_string(c.error());
  EXPECT_EQ(c->source, "synthetic:?frames=6");
  EXPECT_EQ(c->width, 160);
  EXPECT_EQ(c->height, 120);
  EXPECT_EQ(c->max_frames, 4);
  EXPECT_EQ(c->out_dir, "o");
  EXPECT_FALSE(c->progress);
  EXPECT_FALSE(c->write_map);
  EXPECT_EQ(c->surfel_capacity, 1234);
  EXPECT_EQ(c->depth_cutoff_m, 3.0f);
  EXPECT_FALSE(c->labels);
  EXPECT_EQ(c->model, "m.efm");
  EXPECT_EQ(c->label_every, 2);
  EXPECT_EQ(c->labels_out, "l");
  EXPECT_EQ(c->labels_out_every, 4);
  EXPECT_FALSE(c->label_visibility);
  EXPECT_EQ(c->crf_every, 9);
  EXPECT_TRUE(c->crf_final);
  EXPECT_EQ(c->crf_iterations, 3);
  EXPECT_EQ(c->memory_budget_mb, 99);
}

TEST(ConfigYaml, UrisEndingInAColonNeedNoQuotes) {
  for (const char* text : {"source: openni2:\n", "source: openni2:   # the first camera\n", "source: 'openni2:'\n",
                           "source: \"openni2:\"\n", "labels: {enabled: true}\nsource:  openni2:\n",
                           "source: openni2:\r\nframes: 3\r\n"}) {
    auto c = read_text(text);
    ASSERT_TRUE(c.ok()) << text << ": " << to_string(c.error());
    EXPECT_EQ(c->source, "openni2:") << text;
  }
  auto c = read_text("source: synthetic:office?size=320x240\n");
  ASSERT_TRUE(c.ok()) << to_string(c.error());
  EXPECT_EQ(c->source, "synthetic:office?size=320x240");
}

TEST(ConfigYaml, EmptyFileAndCommentsKeepTheDefaults) {
  for (const char* text : {"", "# nothing\n", "---\n"}) {
    auto c = read_text(text);
    ASSERT_TRUE(c.ok()) << to_string(c.error());
    expect_same(*c, RunConfig());
  }
}

struct BadCase {
  const char* text;
  std::vector<const char*> expected;  // substrings of the message
};

TEST(ConfigYaml, EveryErrorNamesFileLineKeyAndValue) {
  const std::vector<BadCase> cases = {
      {"# c\nsource: synthetic:\nresolution: 320x240\nframez: 3\n", {"test.yaml", "line 4", "'framez'"}},
      {"resolution: big\n", {"line 1", "'resolution'", "big"}},
      {"labels: maybe\n", {"line 1", "'labels'", "maybe"}},
      {"crf_iterations: 1000\n", {"line 1", "'crf_iterations'", "1000", "1..100"}},
      {"crf:\n  every: 5\n  iterations: 1000\n", {"line 3", "'crf.iterations'", "1000"}},
      {"crf: {iterationz: 3}\n", {"line 1", "unknown key 'crf.iterationz'"}},
      {"mapping:\n  surfel_capacity: lots\n", {"line 2", "'mapping.surfel_capacity'", "lots"}},
      {"mapping:\n  surfel_capacity: 0\n", {"line 2", "'mapping.surfel_capacity'", "'0'"}},
      {"mapping: {depth_cutoff_m: -1}\n", {"'mapping.depth_cutoff_m'", "-1"}},
      {"mapping: {rgb_boost_condition: 0.5}\n", {"'mapping.rgb_boost_condition'", "0 (off) or > 1"}},
      {"mapping: {rgb_boost_max: 0.5}\n", {"'mapping.rgb_boost_max'", ">= 1"}},
      {"mapping: {index_map_scale: 8}\n", {"'mapping.index_map_scale'", "'8'", "1..4"}},
      {"memory: {budget_mb: 0}\n", {"'memory.budget_mb'", "'0'"}},
      {"labels: {every: 0}\n", {"'labels.every'", "'0'"}},
      {"labels: {model: }\n", {"'labels.model'", "empty"}},
      {"frames: 0\n", {"'frames'", "'0'"}},
      {"mapping: 3\n", {"line 1", "'mapping'", "'3'", "section"}},
      {"mapping: {surfel_capacity: [1, 2]}\n", {"'mapping.surfel_capacity'", "a list"}},
      {"source: [a, b]\n", {"'source'", "a list"}},
      {"mapping: {labels: {every: 2}}\n", {"unknown key 'mapping.labels'"}},
      {"crf: {crf_every: 2}\n", {"unknown key 'crf.crf_every'", "crf.every"}},
      {"source: a:\nsource: b:\n", {"line 2", "'source'", "line 1"}},
      {"label_every: 3\nlabels: {every: 4}\n", {"line 2", "'labels.every'", "line 1"}},
      {"mapping: {surfel_capacity: 10\nresolution: 320x240\n", {"test.yaml", "line", "YAML syntax error"}},
      {"resolution: 320x240\n  bad indentation: 1\n", {"test.yaml", "line 2", "YAML syntax error"}},
      {"- a\n- b\n", {"test.yaml", "line 1", "key: value"}},
      {"pipeline: {threads: 4}\n", {"line 1", "'pipeline.threads'", "'4'", "1..3"}},
      {"threads: 0\n", {"'threads'", "'0'", "1..3"}},
      {"pipeline: {cnn_cpu: x}\n", {"'pipeline.cnn_cpu'", "'x'"}},
      {"pipeline:\n  prepared_slots: 1\n", {"line 2", "'pipeline.prepared_slots'", "2..16"}},
      {"pipeline: {capture_slots: 65}\n", {"'pipeline.capture_slots'", "65", "2..64"}},
      {"pipeline: {front_cpu: -2}\n", {"'pipeline.front_cpu'", "-2", "not pinned"}},
  };
  for (const BadCase& bc : cases) {
    RunConfig c;
    c.surfel_capacity = 777;
    const Status s = apply_config_text(bc.text, "test.yaml", c);
    ASSERT_FALSE(s.ok()) << bc.text;
    EXPECT_EQ(s.error().code, ErrorCode::kInvalidArgument) << bc.text;
    const std::string msg = to_string(s.error());
    EXPECT_NE(msg.find("test.yaml"), std::string::npos) << bc.text << " -> " << msg;
    for (const char* e : bc.expected) EXPECT_NE(msg.find(e), std::string::npos) << bc.text << " -> " << msg;
    EXPECT_EQ(c.surfel_capacity, 777) << "a file with an error must leave the configuration as it was: " << bc.text;
  }
  RunConfig c;
  const Status s = apply_config_file("/nonexistent/edgefusion.yaml", c);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kNotFound);
  EXPECT_NE(to_string(s.error()).find("/nonexistent/edgefusion.yaml"), std::string::npos);
}

TEST(ConfigYaml, DescribeDocumentsEveryKeyWithItsDefault) {
  const std::string text = describe_config(RunConfig());
  for (const std::string& key : config_keys()) {
    const auto dot = key.find('.');
    const std::string name = dot == std::string::npos ? key : key.substr(dot + 1);
    const auto section_at = dot == std::string::npos ? 0 : text.find("\n" + key.substr(0, dot) + ":\n");
    ASSERT_NE(section_at, std::string::npos) << key;
    const auto at = text.find(name + ":", section_at);
    ASSERT_NE(at, std::string::npos) << key << " missing in\n" << text;
    const std::string line = text.substr(at, text.find('\n', at) - at);
    EXPECT_NE(line.find("default"), std::string::npos) << key << ": " << line;
  }
  for (const char* section : {"\nmapping:\n", "\nlabels:\n", "\ncrf:\n", "\nmemory:\n"})
    EXPECT_NE(text.find(section), std::string::npos) << section;
  // Whole numbers are written in full, not as the shortest %g ("1e+01").
  EXPECT_NE(text.find("icp_weight: 10 "), std::string::npos) << text;
  EXPECT_NE(text.find("rgb_boost_condition: 500 "), std::string::npos) << text;
  EXPECT_EQ(text.find("e+0"), std::string::npos) << text;
}

TEST(ConfigYaml, DescribeReadsBackToTheSameConfiguration) {
  const RunConfig defaults;
  auto back = read_text(describe_config(defaults));
  ASSERT_TRUE(back.ok()) << to_string(back.error()) << "\n" << describe_config(defaults);
  expect_same(*back, defaults);

  RunConfig c;  // every field away from its default; strings YAML would misread unquoted
  c.source = "tum:/data/my room #1: \"quoted\"\\";
  c.width = 640;
  c.height = 480;
  c.max_frames = 123;
  c.out_dir = "out dir: x";
  c.progress = false;
  c.write_map = false;
  c.realtime = true;
  c.surfel_capacity = 54321;
  c.icp_weight = 0.1;
  c.rgb_weight = 1.0 / 3.0;
  c.rgb_boost_condition = 0;
  c.rgb_boost_max = 2.5;
  c.depth_cutoff_m = 3.3f;
  c.index_map_scale = 3;
  c.associate_at_tracked_pose = false;
  c.constant_velocity_guess = true;
  c.labels = false;
  c.model = "{model}.efm";
  c.label_every = 7;
  c.labels_out = "[labels]";
  c.labels_out_every = 11;
  c.labels_final_out = "labels at the end";
  c.label_visibility = false;
  c.crf_every = 500;
  c.crf_final = true;
  c.crf_iterations = 100;
  c.memory_budget_mb = 1024;
  c.threads = 1;
  c.prepared_slots = 16;
  c.capture_slots = 2;
  c.front_cpu = 3;
  c.cnn_cpu = 2;
  c.mapping_cpu = 0;
  c.capture_cpu = 1023;
  c.gpio.led.chip = "pinctrl-bcm2711";
  c.gpio.led.offset = 17;
  c.gpio.led.active_low = true;
  c.gpio.button.chip = "/dev/gpiochip0";
  c.gpio.button.offset = 27;
  c.gpio.button.active_low = false;
  c.gpio.debounce_ms = 45;
  c.gpio.optional = true;
  back = read_text(describe_config(c));
  ASSERT_TRUE(back.ok()) << to_string(back.error()) << "\n" << describe_config(c);
  expect_same(*back, c);
}

TEST(ConfigYaml, CommandLineOverridesTheFile) {
  const auto dir = test::scratch_dir("config-overrides");
  const auto cfg = dir / "c.yaml";
  std::ofstream(cfg) << "mapping: {surfel_capacity: 1000}\nlabels: {every: 5}\nmemory: {budget_mb: 100}\n";
  std::vector<std::string> words = {"edgefusion", "plan",          "--config",          cfg.string(),
                                    "--label-every", "3",          "--memory-budget-mb", "50",
                                    "--no-labels",  "--surfel-capacity", "2000"};
  std::vector<char*> argv;
  for (auto& w : words) argv.push_back(w.data());
  auto args = parse_args("edgefusion plan", config_override_options(), 0, int(argv.size()), argv.data(), 2);
  ASSERT_TRUE(args.ok()) << to_string(args.error());
  auto c = config_from_args(*args);
  ASSERT_TRUE(c.ok()) << to_string(c.error());
  EXPECT_EQ(c->surfel_capacity, 2000);
  EXPECT_EQ(c->label_every, 3);
  EXPECT_EQ(c->memory_budget_mb, 50);
  EXPECT_FALSE(c->labels);

  words = {"edgefusion", "plan", "--crf-iterations", "0"};
  argv.clear();
  for (auto& w : words) argv.push_back(w.data());
  args = parse_args("edgefusion plan", config_override_options(), 0, int(argv.size()), argv.data(), 2);
  ASSERT_TRUE(args.ok());
  c = config_from_args(*args);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(to_string(c.error()).find("--crf-iterations"), std::string::npos) << to_string(c.error());
}

// A configuration small enough to create every object for real, also under qemu.
RunConfig small_config() {
  RunConfig c;
  c.source = "synthetic:?size=320x240";
  c.width = 160;
  c.height = 120;
  c.surfel_capacity = 20000;
  c.crf_final = true;
  return c;
}

TEST(PlanMemory, ListsEveryPartAndTheTotal) {
  RunConfig c;  // the defaults: labels on, CRF off, 1,000,000 surfels, 320x240
  auto plan = plan_memory(c);
  ASSERT_TRUE(plan.ok()) << to_string(plan.error());
  std::size_t sum = 0;
  for (const MemoryPart& p : plan->parts) {
    EXPECT_GT(p.bytes, 0u) << p.name;
    sum += p.bytes;
  }
  EXPECT_EQ(plan->total_bytes, sum);
  EXPECT_EQ(plan->budget_bytes, 256u * 1000 * 1000);
  for (const char* part : {"source frame", "prepared frames", "slam tracker", "surfel pool", "surfel spatial order",
                           "model prediction", "surfel fusion scratch", "stage statistics", "cnn model", "cnn arena",
                           "cnn packed weights", "segmenter buffers", "label fusion", "label rendering",
                           "map.ply class columns"})
    EXPECT_GT(plan->bytes_of(part), 0u) << part << " missing in\n" << plan->table();
  EXPECT_EQ(plan->bytes_of("dense crf"), 0u);  // off by default
  EXPECT_EQ(plan->bytes_of("final label pass"), 0u);  // only with labels.final_out
  {
    // docs/architecture.md: a 640x480 and a 320x240 frame, a CNN result, the rendering and a predictor
    // of the whole map: 10.7 MB, on top of everything else.
    RunConfig with_pass = c;
    with_pass.labels_final_out = "final";
    auto pf = plan_memory(with_pass);
    ASSERT_TRUE(pf.ok()) << to_string(pf.error());
    EXPECT_NEAR(double(pf->bytes_of("final label pass")), 10.7e6, 0.1e6);
    EXPECT_EQ(pf->total_bytes - plan->total_bytes, pf->bytes_of("final label pass"));
  }
  // docs/architecture.md, memory budget: 60 bytes per surfel; 640x480 x 8 source frame; the 1x index
  // map (24 bytes per cell) 1.8 MB of the 6.4 MB of prediction at 320x240; fusion scratch 1.1 MB;
  // spatial order 9.0 MB.
  EXPECT_NEAR(double(plan->bytes_of("surfel pool")), 60e6, 1e3);
  EXPECT_EQ(plan->bytes_of("source frame"), 640u * 480 * 8);
  EXPECT_NEAR(double(plan->bytes_of("model prediction")), 6.4e6, 0.1e6);
  EXPECT_NEAR(double(plan->bytes_of("surfel fusion scratch")), 1.10e6, 0.01e6);
  EXPECT_NEAR(double(plan->bytes_of("surfel spatial order")), 9.0e6, 0.1e6);
  EXPECT_NEAR(double(plan->bytes_of("map.ply class columns")), 5e6, 1);
  EXPECT_TRUE(plan->within_budget()) << plan->table();
  // mapping.index_map_scale 4 (ElasticFusion's): the index map is sixteen times larger (1280x960 cells
  // instead of 320x240), and so are fusion's marks and its list of seen surfels.
  {
    RunConfig fine = c;
    fine.index_map_scale = 4;
    auto p4 = plan_memory(fine);
    ASSERT_TRUE(p4.ok()) << to_string(p4.error());
    EXPECT_EQ(p4->bytes_of("model prediction") - plan->bytes_of("model prediction"), (1280u * 960 - 320u * 240) * 24);
    EXPECT_NEAR(double(p4->bytes_of("surfel fusion scratch")), 5.9e6, 0.1e6);
  }

  // Geometry only: no segmenter parts, no model file needed.
  c.labels = false;
  c.model = "/nonexistent/model.efm";
  plan = plan_memory(c);
  ASSERT_TRUE(plan.ok()) << to_string(plan.error());
  EXPECT_EQ(plan->bytes_of("cnn arena"), 0u);
  EXPECT_EQ(plan->bytes_of("map.ply class columns"), 0u);
}

TEST(PlanMemory, MatchesWhatTheObjectsAllocate) {
  const RunConfig c = small_config();
  auto plan = plan_memory(c);
  ASSERT_TRUE(plan.ok()) << to_string(plan.error());
  EXPECT_EQ(plan->bytes_of("source frame"), 320u * 240 * 8);

  const Intrinsics working = Intrinsics{525.f, 525.f, 319.5f, 239.5f, 640, 480}.scaled_to(c.width, c.height);
  slam::SurfelSlamOptions so;
  so.pool.capacity = c.surfel_capacity;
  auto slam = slam::SurfelSlam::create(working, so);
  ASSERT_TRUE(slam.ok()) << to_string(slam.error());
  EXPECT_EQ(plan->bytes_of("surfel pool"), slam->pool_bytes());
  EXPECT_EQ(plan->bytes_of("surfel spatial order"), slam->spatial_order_bytes());
  EXPECT_EQ(plan->bytes_of("model prediction"), slam->predictor().bytes());
  auto fusion = slam::SurfelFusion::create(working, so.prediction.index_map_scale, c.surfel_capacity, so.fusion);
  ASSERT_TRUE(fusion.ok());
  EXPECT_EQ(plan->bytes_of("surfel fusion scratch"), fusion->bytes());

  auto seg = semantic::Segmenter::create(default_model_path());
  ASSERT_TRUE(seg.ok()) << to_string(seg.error());
  EXPECT_EQ(plan->bytes_of("segmenter buffers"), (*seg)->buffer_bytes());
  EXPECT_EQ(plan->bytes_of("cnn arena"), (*seg)->executor().arena_bytes());
  EXPECT_GE(plan->bytes_of("cnn packed weights"), (*seg)->executor().packed_bytes());
  EXPECT_LE(plan->bytes_of("cnn packed weights"), (*seg)->executor().packed_bytes() + 64);

  // The pipeline's prepared slots and the SLAM's preprocessor, as `run` creates them.
  RunConfig with_out = c;
  with_out.out_dir = test::scratch_dir("plan-pipeline").string();
  auto source = open_source(c.source);
  ASSERT_TRUE(source.ok());
  StageStats stats;
  auto pipeline = RunPipeline::create(with_out, **source, stats);
  ASSERT_TRUE(pipeline.ok()) << to_string(pipeline.error());
  EXPECT_EQ(plan->bytes_of("prepared frames"), static_cast<std::size_t>(c.prepared_slots) * (*pipeline)->slot_bytes());
  EXPECT_EQ(plan->bytes_of("slam preprocessing"), 0u);  // run's SLAM has none of its own

  auto crf = semantic::DenseCrf::create(run_crf_options(c));  // the options `run` creates it with
  ASSERT_TRUE(crf.ok()) << to_string(crf.error());
  // Within 1%: semantic/dense_crf.* is young; a layout change there should show up here.
  EXPECT_NEAR(double(plan->bytes_of("dense crf")), double(crf->bytes()), 0.01 * double(crf->bytes()))
      << plan->table();

  // The final label pass (src/pipeline/final_labels.h) over this run's map, after the run.
  RunConfig with_final = c;
  with_final.labels_final_out = (fs::path(with_out.out_dir) / "final").string();
  auto final_plan = plan_memory(with_final);
  ASSERT_TRUE(final_plan.ok()) << to_string(final_plan.error());
  EXPECT_EQ(plan->bytes_of("final label pass"), 0u);  // only planned when asked for
  StageStats semantic_stats;
  auto semantics = RunSemantics::create(with_final, working, semantic_stats);
  ASSERT_TRUE(semantics.ok()) << to_string(semantics.error());
  auto final_pass = FinalLabelBuffers::create(with_final, (*source)->info(), *slam, **semantics);
  ASSERT_TRUE(final_pass.ok()) << to_string(final_pass.error());
  EXPECT_EQ(final_plan->bytes_of("final label pass"), final_pass->bytes()) << final_plan->table();
}

TEST(PlanMemory, OverBudgetIsRefusedWithTheNumbers) {
  RunConfig c;
  c.surfel_capacity = 2'000'000;
  c.crf_final = true;  // 2M x (60 + 588 + 5) bytes alone is 1.3 GB
  auto plan = plan_memory(c);
  ASSERT_TRUE(plan.ok()) << to_string(plan.error());
  EXPECT_FALSE(plan->within_budget());
  const Status s = check_memory_budget(c);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kResourceExhausted);
  const std::string msg = to_string(s.error());
  for (const char* e : {"256 MB", "memory.budget_mb", "dense crf", "surfel pool", "surfel_capacity"})
    EXPECT_NE(msg.find(e), std::string::npos) << e << " in " << msg;

  c.memory_budget_mb = 2000;
  EXPECT_TRUE(check_memory_budget(c).ok());
  c.memory_budget_mb = 256;
  c.crf_final = false;
  c.surfel_capacity = 1'000'000;
  EXPECT_TRUE(check_memory_budget(c).ok());

  c.model = "/nonexistent/model.efm";
  const Status m = check_memory_budget(c);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(to_string(m.error()).find("/nonexistent/model.efm"), std::string::npos);
}

TEST(PlanCli, PrintsTheTableAndExitsByTheBudget) {
  auto r = cli({"plan", "--source", "synthetic:?size=320x240", "--surfel-capacity", "100000"});
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* e : {"surfel pool", "6000000", "total", "budget", "within budget"})
    EXPECT_NE(r.out.find(e), std::string::npos) << e << " in\n" << r.out;

  r = cli({"plan", "--surfel-capacity", "3000000", "--crf-final"});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("over budget"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("dense crf"), std::string::npos) << r.out;

  const auto dir = test::scratch_dir("plan-cli");
  std::ofstream(dir / "c.yaml") << "memory: {budget_mb: 5000}\n";
  r = cli({"plan", "--config", (dir / "c.yaml").string(), "--surfel-capacity", "3000000", "--crf-final"});
  EXPECT_EQ(r.code, 0) << r.err;

  std::ofstream(dir / "c.yaml") << "memory: {budget_mb: lots}\n";
  r = cli({"plan", "--config", (dir / "c.yaml").string()});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("memory.budget_mb"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("lots"), std::string::npos) << r.err;

  r = cli({"plan", "--help"});
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("budget_mb: 256"), std::string::npos) << r.out;
  r = cli({"--help"});
  EXPECT_NE(r.out.find("plan"), std::string::npos);
}

TEST(ConfigExample, Arm64ExampleIsValidAndWithinItsBudget) {
  RunConfig c;
  const Status s = apply_config_file(kExampleConfig, c);
  ASSERT_TRUE(s.ok()) << to_string(s.error());
  EXPECT_EQ(c.source.rfind("openni2:", 0), 0u) << c.source;
  EXPECT_EQ(c.width, 320);
  EXPECT_EQ(c.height, 240);
  EXPECT_EQ(c.label_every, 10);
  EXPECT_TRUE(c.labels);
  EXPECT_EQ(c.memory_budget_mb, 256);
  EXPECT_FALSE(c.out_dir.empty());
  auto plan = plan_memory(c);
  ASSERT_TRUE(plan.ok()) << to_string(plan.error());
  EXPECT_TRUE(plan->within_budget()) << plan->table();
  EXPECT_TRUE(check_memory_budget(c).ok());

  const auto r = cli({"plan", "--config", kExampleConfig});
  EXPECT_EQ(r.code, 0) << r.out << r.err;
}

}  // namespace
}  // namespace ef::app
