// The configuration of `run` and `plan` as a user gives it (firmware_app/config_file.h over the
// option tables of pipeline/run_config.h): sections and flat keys, errors that name the file, line,
// key and value, describe() as a file that reads back to the same configuration, the command line
// over the file; `edgefusion plan`: its table and exit codes, that it refuses whatever `run` refuses,
// the pinned cores of the ARM64 example on a machine that lacks them; the README's key list.
#include <gtest/gtest.h>

#include <sched.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "app/cli_test_util.h"
#include "firmware_app/args.h"
#include "firmware_app/config_file.h"
#include "pipeline/memory_plan.h"
#include "platform/cpu/thread_affinity.h"
#include "platform/devices/cameras.h"
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

// Two configurations key by key (every key the option tables bind, named in the failure message;
// a key added later is compared too).
void expect_same(const RunConfig& a, const RunConfig& b) {
  for (const ConfigKey& k : config_keys()) EXPECT_EQ(opt::yaml_text(k.get(a)), opt::yaml_text(k.get(b))) << k.path;
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
  EXPECT_EQ(c->run.source, "synthetic:");
  EXPECT_EQ(c->mapping.pool.capacity, 500000);
  EXPECT_EQ(c->mapping.tracker.icp_weight, 5.0);
  EXPECT_EQ(c->mapping.tracker.rgb_weight, 0.5);
  EXPECT_EQ(c->mapping.preprocess.depth_cutoff_m, 4.5f);
  EXPECT_EQ(c->mapping.prediction.index_map_scale, 2);
  EXPECT_FALSE(c->mapping.associate_at_tracked_pose);
  EXPECT_TRUE(c->labels.enabled);
  EXPECT_EQ(c->labels.model, "net.efm");
  EXPECT_EQ(c->label_fusion.update_every_n_frames, 5);
  EXPECT_EQ(c->labels.out, "lab");
  EXPECT_EQ(c->labels.out_every, 3);
  EXPECT_FALSE(c->label_fusion.visibility_test);
  EXPECT_EQ(c->crf.every, 100);
  EXPECT_TRUE(c->crf.final);
  EXPECT_EQ(c->dense_crf.iterations, 7);
  EXPECT_EQ(c->memory.budget_mb, 512);
}

// Issue 30: every threshold of the lost verdict, relocalisation and loop closure is a key (the
// deformation graph's sizes and weights too), read into the options the SLAM is built from, and a
// value out of its range is refused naming the key.
TEST(ConfigYaml, LostAndLoopClosureThresholdsAreKeys) {
  auto c = read_text(
      "mapping:\n"
      "  lost_min_inlier_fraction: 0.05\n  lost_min_inliers: 500\n  lost_max_icp_rms_m: 0.03\n"
      "  lost_max_rgb_rms_grey: 30\n  lost_max_correction_m: 0.2\n  lost_max_correction_deg: 15\n"
      "  loop_sample_step: 8\n  deformation_max_nodes: 512\n  deformation_surfels_per_node: 2000\n"
      "  deformation_neighbours: 6\n  deformation_max_constraints: 1000\n  deformation_iterations: 5\n"
      "  deformation_weight_rotation: 2\n  deformation_weight_regularisation: 20\n"
      "  deformation_weight_constraint: 50\n");
  ASSERT_TRUE(c.ok()) << to_string(c.error());
  const auto& t = c->mapping.tracker;
  EXPECT_EQ(t.lost_min_inlier_fraction, 0.05);
  EXPECT_EQ(t.lost_min_inliers, 500);
  EXPECT_EQ(t.lost_max_icp_rms_m, 0.03);
  EXPECT_EQ(t.lost_max_rgb_rms_grey, 30.0);
  EXPECT_EQ(t.lost_max_correction_m, 0.2);
  EXPECT_EQ(t.lost_max_correction_deg, 15.0);
  EXPECT_EQ(c->mapping.loop_sample_step, 8);
  const auto& g = c->mapping.graph;
  EXPECT_EQ(g.max_nodes, 512);
  EXPECT_EQ(g.surfels_per_node, 2000);
  EXPECT_EQ(g.neighbours, 6);
  EXPECT_EQ(g.max_constraints, 1000);
  EXPECT_EQ(g.iterations, 5);
  EXPECT_EQ(g.weight_rotation, 2.0);
  EXPECT_EQ(g.weight_regularisation, 20.0);
  EXPECT_EQ(g.weight_constraint, 50.0);
  EXPECT_TRUE(c->mapping.validate().ok());

  for (const auto& [text, key] : std::vector<std::pair<std::string, std::string>>{
           {"mapping: {lost_min_inlier_fraction: 1.5}\n", "mapping.lost_min_inlier_fraction"},
           {"mapping: {lost_max_icp_rms_m: 0}\n", "mapping.lost_max_icp_rms_m"},
           {"mapping: {deformation_neighbours: 9}\n", "mapping.deformation_neighbours"},
           {"mapping: {deformation_weight_constraint: -1}\n", "mapping.deformation_weight_constraint"},
           {"mapping: {loop_sample_step: 0}\n", "mapping.loop_sample_step"}}) {
    auto bad = read_text(text);
    ASSERT_FALSE(bad.ok()) << text;
    EXPECT_NE(to_string(bad.error()).find(key), std::string::npos) << text << ": " << to_string(bad.error());
  }
  // The struct's own check holds the same ranges (the table's rows are its only copy).
  ef::slam::DeformationGraphOptions g2;
  g2.neighbours = 9;
  EXPECT_FALSE(g2.validate().ok());
  g2.neighbours = 8;
  EXPECT_TRUE(g2.validate().ok());
}

TEST(ConfigYaml, FlatKeysStillWork) {
  auto c = read_text(
      "# flat\nsource: synthetic:?frames=6\nresolution: 160x120\nframes: 4\nout: o\nprogress: off\nmap: no\n"
      "surfel_capacity: 1234\nicp_weight: 1\nrgb_weight: 2\ndepth_cutoff_m: 3\nlabels: false\nmodel: m.efm\n"
      "label_every: 2\nlabels_out: l\nlabels_out_every: 4\nlabel_visibility: false\ncrf_every: 9\ncrf_final: yes\n"
      "crf_iterations: 3\nmemory_budget_mb: 99\n");
  ASSERT_TRUE(c.ok()) << to_string(c.error());
  EXPECT_EQ(c->run.source, "synthetic:?frames=6");
  EXPECT_EQ(c->run.resolution.width, 160);
  EXPECT_EQ(c->run.resolution.height, 120);
  EXPECT_EQ(c->run.frames, 4);
  EXPECT_EQ(c->run.out, "o");
  EXPECT_FALSE(c->run.progress);
  EXPECT_FALSE(c->run.map);
  EXPECT_EQ(c->mapping.pool.capacity, 1234);
  EXPECT_EQ(c->mapping.preprocess.depth_cutoff_m, 3.0f);
  EXPECT_FALSE(c->labels.enabled);
  EXPECT_EQ(c->labels.model, "m.efm");
  EXPECT_EQ(c->label_fusion.update_every_n_frames, 2);
  EXPECT_EQ(c->labels.out, "l");
  EXPECT_EQ(c->labels.out_every, 4);
  EXPECT_FALSE(c->label_fusion.visibility_test);
  EXPECT_EQ(c->crf.every, 9);
  EXPECT_TRUE(c->crf.final);
  EXPECT_EQ(c->dense_crf.iterations, 3);
  EXPECT_EQ(c->memory.budget_mb, 99);
}

TEST(ConfigYaml, UrisEndingInAColonNeedNoQuotes) {
  for (const char* text : {"source: openni2:\n", "source: openni2:   # the first camera\n", "source: 'openni2:'\n",
                           "source: \"openni2:\"\n", "labels: {enabled: true}\nsource:  openni2:\n",
                           "source: openni2:\r\nframes: 3\r\n"}) {
    auto c = read_text(text);
    ASSERT_TRUE(c.ok()) << text << ": " << to_string(c.error());
    EXPECT_EQ(c->run.source, "openni2:") << text;
  }
  auto c = read_text("source: synthetic:office?size=320x240\n");
  ASSERT_TRUE(c.ok()) << to_string(c.error());
  EXPECT_EQ(c->run.source, "synthetic:office?size=320x240");
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
      {"mapping: {rgb_boost_condition: 0.5}\n", {"'mapping.rgb_boost_condition'", "> 1 or 0 (off)"}},
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
    c.mapping.pool.capacity = 777;
    const Status s = apply_config_text(bc.text, "test.yaml", c);
    ASSERT_FALSE(s.ok()) << bc.text;
    EXPECT_EQ(s.error().code, ErrorCode::kInvalidArgument) << bc.text;
    const std::string msg = to_string(s.error());
    EXPECT_NE(msg.find("test.yaml"), std::string::npos) << bc.text << " -> " << msg;
    for (const char* e : bc.expected) EXPECT_NE(msg.find(e), std::string::npos) << bc.text << " -> " << msg;
    EXPECT_EQ(c.mapping.pool.capacity, 777) << "a file with an error must leave the configuration as it was: " << bc.text;
  }
  RunConfig c;
  const Status s = apply_config_file("/nonexistent/edgefusion.yaml", c);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kNotFound);
  EXPECT_NE(to_string(s.error()).find("/nonexistent/edgefusion.yaml"), std::string::npos);
}

TEST(ConfigYaml, DescribeDocumentsEveryKeyWithItsDefault) {
  const std::string text = RunConfig().describe();
  for (const ConfigKey& k : config_keys()) {
    const std::string& key = k.path;
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
  auto back = read_text(defaults.describe());
  ASSERT_TRUE(back.ok()) << to_string(back.error()) << "\n" << defaults.describe();
  expect_same(*back, defaults);

  RunConfig c;  // every field away from its default; strings YAML would misread unquoted
  c.run.source = "tum:/data/my room #1: \"quoted\"\\";
  c.run.resolution.width = 640;
  c.run.resolution.height = 480;
  c.run.frames = 123;
  c.run.out = "out dir: x";
  c.run.progress = false;
  c.run.map = false;
  c.run.realtime = true;
  c.mapping.pool.capacity = 54321;
  c.mapping.tracker.icp_weight = 0.1;
  c.mapping.tracker.rgb_weight = 1.0 / 3.0;
  c.mapping.tracker.rgb_boost_condition = 0;
  c.mapping.tracker.rgb_boost_max = 2.5;
  c.mapping.preprocess.depth_cutoff_m = 3.3f;
  c.mapping.prediction.index_map_scale = 3;
  c.mapping.associate_at_tracked_pose = false;
  c.mapping.constant_velocity_guess = true;
  c.labels.enabled = false;
  c.labels.model = "{model}.efm";
  c.label_fusion.update_every_n_frames = 7;
  c.labels.out = "[labels]";
  c.labels.out_every = 11;
  c.labels.final_out = "labels at the end";
  c.label_fusion.visibility_test = false;
  c.crf.every = 500;
  c.crf.final = true;
  c.dense_crf.iterations = 100;
  c.memory.budget_mb = 1024;
  c.pipeline.threads = 1;
  c.pipeline.prepared_slots = 16;
  c.pipeline.capture_slots = 2;
  c.pipeline.front_cpu = 3;
  c.pipeline.cnn_cpu = 2;
  c.pipeline.mapping_cpu = 0;
  c.pipeline.capture_cpu = 1023;
  c.gpio.led.chip = "pinctrl-bcm2711";
  c.gpio.led.offset = 17;
  c.gpio.led.active_low = true;
  c.gpio.button.chip = "/dev/gpiochip0";
  c.gpio.button.offset = 27;
  c.gpio.button.active_low = false;
  c.gpio.debounce_ms = 45;
  c.gpio.optional = true;
  back = read_text(c.describe());
  ASSERT_TRUE(back.ok()) << to_string(back.error()) << "\n" << c.describe();
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
  EXPECT_EQ(c->mapping.pool.capacity, 2000);
  EXPECT_EQ(c->label_fusion.update_every_n_frames, 3);
  EXPECT_EQ(c->memory.budget_mb, 50);
  EXPECT_FALSE(c->labels.enabled);

  words = {"edgefusion", "plan", "--crf-iterations", "0"};
  argv.clear();
  for (auto& w : words) argv.push_back(w.data());
  args = parse_args("edgefusion plan", config_override_options(), 0, int(argv.size()), argv.data(), 2);
  ASSERT_TRUE(args.ok());
  c = config_from_args(*args);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(to_string(c.error()).find("--crf-iterations"), std::string::npos) << to_string(c.error());
}

TEST(PlanCli, PrintsTheTableAndExitsByTheBudget) {
  const auto dir = test::scratch_dir("plan-cli");
  const std::string out = (dir / "out").string();
  auto r = cli({"plan", "--source", "synthetic:?size=320x240", "--surfel-capacity", "100000", "--out", out});
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* e : {"surfel pool", "6000000", "total", "budget", "within budget"})
    EXPECT_NE(r.out.find(e), std::string::npos) << e << " in\n" << r.out;
  EXPECT_FALSE(fs::exists(out)) << "plan must not create the output folder";

  r = cli({"plan", "--surfel-capacity", "3000000", "--crf-final", "--out", out});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("over budget"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("dense crf"), std::string::npos) << r.out;

  std::ofstream(dir / "c.yaml") << "memory: {budget_mb: 5000}\n";
  r = cli({"plan", "--config", (dir / "c.yaml").string(), "--surfel-capacity", "3000000", "--crf-final", "--out", out});
  EXPECT_EQ(r.code, 0) << r.err;

  std::ofstream(dir / "c.yaml") << "memory: {budget_mb: lots}\n";
  r = cli({"plan", "--config", (dir / "c.yaml").string(), "--out", out});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("memory.budget_mb"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("lots"), std::string::npos) << r.err;

  r = cli({"plan", "--help"});
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("budget_mb: 256"), std::string::npos) << r.out;
  r = cli({"--help"});
  EXPECT_NE(r.out.find("plan"), std::string::npos);
}

// `plan` refuses every command line that `run` refuses before its first frame, with the same
// reason: both take the same options and call the same checks (RunConfig::validate, check_run, the
// model, the memory plan). Exit codes: `run` 2 for a configuration it refuses and 1 for a source it
// cannot open; `plan` 2 for both, and 1 when over budget.
TEST(PlanCli, RefusesWhatRunRefuses) {
  const auto dir = test::scratch_dir("plan-refuses");
  std::ofstream(dir / "no-terms.yaml") << "mapping: {icp_weight: 0, rgb_weight: 0}\n";
  std::ofstream(dir / "core.yaml") << "pipeline: {threads: 3, cnn_cpu: 1023}\n";
  struct Case {
    std::vector<std::string> args;
    const char* reason;  // in both messages
  };
  std::vector<Case> cases = {
      {{"--no-labels", "--crf-final"}, "need labels"},
      {{"--no-labels", "--labels-out", (dir / "l").string()}, "need labels"},
      {{"--model", "/nonexistent/model.efm"}, "/nonexistent/model.efm"},
      {{"--config", (dir / "no-terms.yaml").string()}, "icp_weight and rgb_weight"},
      {{"--surfel-capacity", "30000000", "--crf-every", "100"}, "dense crf"},
      {{"--source", "synthetic:?sise=320x240"}, "sise"},
      {{"--source", "tum:/nonexistent/tum-folder"}, "/nonexistent/tum-folder"},
      {{"--surfel-capacity", "3000000", "--crf-final"}, "memory.budget_mb"},
  };
  if (usable_cpu_cores().back() < 1023) cases.push_back({{"--config", (dir / "core.yaml").string()}, "pipeline.cnn_cpu 1023"});
  if (openni2_built())
    cases.push_back({{"--source", "openni2:Dummy", "--labels-final-out", (dir / "f").string()}, "live camera"});
  for (const Case& c : cases) {
    std::vector<std::string> run_args = {"run", "--quiet", "--frames", "2", "--out", (dir / "out").string()};
    run_args.insert(run_args.end(), c.args.begin(), c.args.end());
    std::vector<std::string> plan_args = run_args;
    plan_args[0] = "plan";
    const CliResult run = cli(run_args);
    const CliResult plan = cli(plan_args);
    std::string line;
    for (const auto& a : c.args) line += " " + a;
    EXPECT_NE(run.code, 0) << "run" << line << " was accepted";
    EXPECT_NE(plan.code, 0) << "plan" << line << " was accepted";
    EXPECT_NE(run.err.find(c.reason), std::string::npos) << "run" << line << ": " << run.err;
    EXPECT_NE(plan.err.find(c.reason), std::string::npos) << "plan" << line << ": " << plan.err;
  }
  // Without --out both refuse too.
  EXPECT_EQ(cli({"run", "--frames", "1"}).code, 2);
  const CliResult plan = cli({"plan"});
  EXPECT_EQ(plan.code, 2);
  EXPECT_NE(plan.err.find("--out"), std::string::npos) << plan.err;
}

// Restricts the calling thread (and the in-process CLI it runs) to the first `n` cores this
// process may use, for the scope: what a smaller board looks like to the configuration checks.
class FewerCores {
 public:
  explicit FewerCores(int n) {
    sched_getaffinity(0, sizeof saved_, &saved_);
    cpu_set_t set;
    CPU_ZERO(&set);
    const std::vector<int> cores = usable_cpu_cores();
    for (int i = 0; i < n && i < static_cast<int>(cores.size()); ++i) CPU_SET(cores[i], &set);
    ok_ = sched_setaffinity(0, sizeof set, &set) == 0;
  }
  ~FewerCores() { sched_setaffinity(0, sizeof saved_, &saved_); }
  bool ok() const { return ok_; }

 private:
  cpu_set_t saved_{};
  bool ok_ = false;
};

TEST(ConfigExample, Arm64ExampleIsValidAndWithinItsBudget) {
  RunConfig c;
  const Status s = apply_config_file(kExampleConfig, c);
  ASSERT_TRUE(s.ok()) << to_string(s.error());
  EXPECT_EQ(c.run.source.rfind("openni2:", 0), 0u) << c.run.source;
  EXPECT_EQ(c.run.resolution.width, 320);
  EXPECT_EQ(c.run.resolution.height, 240);
  EXPECT_EQ(c.label_fusion.update_every_n_frames, 10);
  EXPECT_TRUE(c.labels.enabled);
  EXPECT_EQ(c.memory.budget_mb, 256);
  EXPECT_FALSE(c.run.out.empty());
  // Its threads are pinned to the cores present (pipeline.pinning auto): every check passes on a
  // board of any core count, and the plan fits the budget.
  EXPECT_EQ(c.pipeline.pinning, "auto");
  for (const std::vector<int>& cores : std::vector<std::vector<int>>{{0}, {0, 1}, {0, 1, 2}, {0, 1, 2, 3}, {0, 1, 2, 3, 4, 5, 6, 7}})
    EXPECT_TRUE(c.validate(cores).ok()) << cores_text(cores) << ": " << to_string(c.validate(cores).error());
  EXPECT_TRUE(c.output.resume_interrupted) << "the service continues a map cut by a power failure";
  if (!openni2_built()) GTEST_SKIP() << "this build has no OpenNI2 (libopenni2-dev): the example's camera cannot be planned";
  auto probe = probe_source(c.run.source);
  ASSERT_TRUE(probe.ok()) << to_string(probe.error());
  auto plan = plan_memory(c, *probe);
  ASSERT_TRUE(plan.ok()) << to_string(plan.error());
  EXPECT_TRUE(plan->within_budget()) << plan->table();
  // And `edgefusion plan` passes it on this machine, whatever its cores.
  const CliResult r = cli({"plan", "--config", kExampleConfig});
  EXPECT_EQ(r.code, 0) << r.out << r.err;
}

// pipeline.pinning auto: mapping on the last core, the CNN before it, the front step before that,
// capture on the first; fewer cores share the first ones; one core pins nothing.
TEST(ConfigExample, AutoPinningFollowsTheCoresPresent) {
  PipelineOptions p;
  p.pinning = "auto";
  struct Case {
    std::vector<int> cores;
    int capture, front, cnn, mapping;
  };
  for (const Case& k : {Case{{0}, -1, -1, -1, -1}, Case{{0, 1}, 0, 0, 0, 1}, Case{{0, 1, 2}, 0, 0, 1, 2},
                        Case{{0, 1, 2, 3}, 0, 1, 2, 3}, Case{{0, 1, 2, 3, 4, 5, 6, 7}, 0, 5, 6, 7},
                        Case{{1, 2, 3}, 1, 1, 2, 3}}) {
    const PipelineOptions q = p.pinned_for(k.cores);
    EXPECT_EQ(q.capture_cpu, k.capture) << cores_text(k.cores);
    EXPECT_EQ(q.front_cpu, k.front) << cores_text(k.cores);
    EXPECT_EQ(q.cnn_cpu, k.cnn) << cores_text(k.cores);
    EXPECT_EQ(q.mapping_cpu, k.mapping) << cores_text(k.cores);
  }
  // "keys" keeps the keys as they are.
  PipelineOptions keys;
  keys.mapping_cpu = 5;
  EXPECT_EQ(keys.pinned_for({0, 1, 2, 3}).mapping_cpu, 5);
  EXPECT_EQ(keys.pinned_for({0, 1, 2, 3}).cnn_cpu, -1);
  // auto beside a pinned key, and an unknown mode, are errors naming the keys.
  PipelineOptions both = p;
  both.cnn_cpu = 2;
  ASSERT_FALSE(both.validate().ok());
  EXPECT_NE(both.validate().error().message.find("cnn_cpu 2"), std::string::npos) << both.validate().error().message;
  PipelineOptions bogus;
  bogus.pinning = "fastest";
  ASSERT_FALSE(bogus.validate().ok());
  EXPECT_NE(bogus.validate().error().message.find("'fastest'"), std::string::npos);
}

// The acceptance of the configuration issue: fixed cores (pipeline.pinning keys) that a board of
// two cores lacks are named by `edgefusion plan` exactly as `run` names them.
TEST(ConfigExample, FixedCoresOnATwoCoreMachineAreNamed) {
  std::string text = read_file(kExampleConfig);
  const std::string automatic = "  pinning: auto";
  const auto at = text.find(automatic);
  ASSERT_NE(at, std::string::npos) << "the example no longer pins automatically";
  text.replace(at, automatic.size(), "  pinning: keys\n  capture_cpu: 0\n  front_cpu: 1\n  cnn_cpu: 2\n  mapping_cpu: 3");
  const auto dir = test::scratch_dir("config-fixed-cores");
  const auto fixed = (dir / "fixed.yaml").string();
  std::ofstream(fixed) << text;
  RunConfig c;
  ASSERT_TRUE(apply_config_file(fixed, c).ok());
  EXPECT_TRUE(c.validate({0, 1, 2, 3}).ok());
  const Status s = c.validate({0, 1});
  ASSERT_FALSE(s.ok());
  const std::string msg = to_string(s.error());
  for (const char* e : {"pipeline.cnn_cpu 2", "pipeline.mapping_cpu 3", "cores 0-1", "-1 (not pinned)"})
    EXPECT_NE(msg.find(e), std::string::npos) << e << " in " << msg;
  for (const char* e : {"capture_cpu", "front_cpu"}) EXPECT_EQ(msg.find(e), std::string::npos) << e << " in " << msg;

  // The same through the command line, with this test's thread held to two cores.
  if (usable_cpu_cores().size() < 2 || usable_cpu_cores()[0] != 0 || usable_cpu_cores()[1] != 1)
    GTEST_SKIP() << "this process may not use cores 0 and 1 (" << cores_text(usable_cpu_cores()) << ")";
  FewerCores two(2);
  ASSERT_TRUE(two.ok());
  ASSERT_EQ(usable_cpu_cores(), (std::vector<int>{0, 1}));
  for (const char* command : {"plan", "run"}) {
    const CliResult r = cli({command, "--config", fixed, "--frames", "1"});
    EXPECT_EQ(r.code, 2) << command << ": " << r.out << r.err;
    EXPECT_NE(r.err.find("pipeline.cnn_cpu 2, pipeline.mapping_cpu 3"), std::string::npos) << command << ": " << r.err;
  }
  // The shipped example itself passes on the same two cores.
  if (openni2_built()) {
    EXPECT_EQ(cli({"plan", "--config", kExampleConfig}).code, 0);
  }
}

// The README's list of configuration keys is the one `edgefusion plan --keys` prints from the
// option tables (regenerate it with that command when a key changes).
TEST(ConfigDocs, ReadmeKeyListIsTheTables) {
  const std::string readme = read_file(EF_SOURCE_DIR "/README.md");
  const std::string begin = "<!-- keys: edgefusion plan --keys -->\n", end = "<!-- /keys -->";
  const auto a = readme.find(begin), b = readme.find(end);
  ASSERT_NE(a, std::string::npos) << "README.md has no key list (" << begin << ")";
  ASSERT_NE(b, std::string::npos);
  const std::string listed = readme.substr(a + begin.size(), b - a - begin.size());
  EXPECT_EQ(listed, config_keys_markdown()) << "README.md's key list is stale: replace it with `edgefusion plan --keys`";
  const CliResult r = cli({"plan", "--keys"});
  EXPECT_EQ(r.code, 0);
  EXPECT_EQ(r.out, config_keys_markdown());
}

// The README quotes no figure of its own: its table of figures is docs/headline.md's, which
// bench/headline.sh measures in one run and copies into both.
TEST(ConfigDocs, ReadmeFiguresAreTheHeadlineTable) {
  const std::string begin = "<!-- headline: bench/headline.sh -->\n", end = "<!-- /headline -->";
  const auto block = [&](const std::string& text, const char* name) {
    const auto a = text.find(begin), b = text.find(end);
    EXPECT_NE(a, std::string::npos) << name << " has no " << begin;
    EXPECT_NE(b, std::string::npos) << name << " has no " << end;
    return a == std::string::npos || b == std::string::npos ? std::string() : text.substr(a + begin.size(), b - a - begin.size());
  };
  const std::string readme = block(read_file(EF_SOURCE_DIR "/README.md"), "README.md");
  const std::string headline = block(read_file(EF_SOURCE_DIR "/docs/headline.md"), "docs/headline.md");
  EXPECT_NE(headline.find("| figure |"), std::string::npos) << "docs/headline.md has no table: run bench/headline.sh";
  EXPECT_EQ(readme, headline) << "README.md's figures differ from docs/headline.md's: run bench/headline.sh";
}

}  // namespace
}  // namespace ef::app
