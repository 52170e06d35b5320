// The option registry (core/options.h, pipeline/run_config.h): every key comes from one row of its
// struct's table, and that row is the one place its range is checked: by parsing a value, by the
// struct's validate() and hence by the class that takes the options. RunConfig::validate(): the
// rules between parts and the machine's cores.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>

#include "core/options.h"
#include "pipeline/run_config.h"
#include "semantic/dense_crf.h"
#include "slam/surfel_slam.h"

namespace ef::pipeline {
namespace {

// A value of a number key's range as text, `below` its minimum (or above its maximum).
std::string outside(const ConfigKey& k, bool below) {
  const opt::Range& r = k.range;
  const bool integer = k.kind == opt::Value::kInt;
  double v;
  if (below) v = r.min_open ? r.min : (integer ? r.min - 1 : r.min - 0.5);
  else v = integer ? r.max + 1 : r.max * 2 + 1;
  if (r.has_special && v == r.special) v += below ? -1 : 1;
  return integer ? std::to_string(static_cast<long long>(v)) : std::to_string(v);
}

// A number as the configuration file would write it.
std::string text_of(double v) {
  opt::Value x;
  x.kind = opt::Value::kReal;
  x.d = v;
  return opt::yaml_text(x);
}

TEST(ConfigKeys, EveryKeyIsOneRowWithItsOwnNamesAndAValidDefault) {
  const RunConfig defaults;
  std::set<std::string> paths, flats, flags;
  ASSERT_GE(config_keys().size(), 40u);
  for (const ConfigKey& k : config_keys()) {
    EXPECT_TRUE(paths.insert(k.path).second) << "path twice: " << k.path;
    if (!k.flat.empty()) {
      EXPECT_TRUE(flats.insert(k.flat).second) << "flat name twice: " << k.flat;
    }
    if (!k.flag.empty()) {
      EXPECT_TRUE(flags.insert(k.flag).second) << "flag twice: " << k.flag;
      EXPECT_EQ(k.flag.rfind("--", 0), 0u) << k.flag;
    }
    EXPECT_FALSE(k.help.empty()) << k.path;
    EXPECT_EQ(find_config_key(k.path), &k);
    if (!k.flat.empty()) {
      EXPECT_EQ(find_config_key(k.flat), &k);
    }
    // The default is the struct's initialiser, and it is within the key's own range.
    const opt::Value d = k.get(defaults);
    if (d.kind != opt::Value::kText) {
      EXPECT_EQ(opt::check_value(d, k.range, k.unit.c_str()), "") << k.path;
    }
    EXPECT_NE(k.doc().find("default"), std::string::npos) << k.path;
  }
  // A flat name is never another key's path.
  for (const std::string& f : flats) EXPECT_EQ(paths.count(f), 0u) << f << " is a flat name and another key's path";
  EXPECT_EQ(config_sections(), (std::vector<std::string>{"mapping", "labels", "crf", "pipeline", "memory", "output", "log", "gpio"}));
}

// Every number key takes its bounds and refuses a value beyond each finite one, naming the range;
// the configuration is left unchanged by a refused value.
TEST(ConfigKeys, RangesComeFromTheTables) {
  int checked = 0;
  for (const ConfigKey& k : config_keys()) {
    if (k.kind != opt::Value::kInt && k.kind != opt::Value::kReal) continue;
    RunConfig c;
    const std::string before = opt::yaml_text(k.get(c));
    if (std::isfinite(k.range.min)) {
      const std::string bad = outside(k, true);
      const std::string why = k.parse(c, bad);
      EXPECT_NE(why, "") << k.path << " took " << bad;
      EXPECT_NE(why.find(k.range.text()), std::string::npos) << k.path << ": " << why;
      EXPECT_EQ(opt::yaml_text(k.get(c)), before) << k.path;
      if (!k.range.min_open) {
        EXPECT_EQ(k.parse(c, text_of(k.range.min)), "") << k.path;
        ++checked;
      }
    }
    if (std::isfinite(k.range.max)) {
      RunConfig d;
      const std::string bad = outside(k, false);
      EXPECT_NE(k.parse(d, bad), "") << k.path << " took " << bad;
      EXPECT_EQ(k.parse(d, text_of(k.range.max)), "") << k.path;
      ++checked;
    }
    if (k.range.has_special) {
      RunConfig d;
      EXPECT_EQ(k.parse(d, text_of(k.range.special)), "") << k.path;
    }
    RunConfig e;
    EXPECT_NE(k.parse(e, "x"), "") << k.path;
  }
  EXPECT_GE(checked, 20);
}

// The range of a row is the one range: the struct's validate() (and so the class that takes the
// options) refuses what parsing refuses, with the same limits.
TEST(ConfigKeys, StructsValidateTheirTableRanges) {
  semantic::DenseCrfOptions crf;
  crf.iterations = 100;
  EXPECT_TRUE(crf.validate().ok());
  crf.iterations = 101;  // the file and the command line refuse it too (ranges above)
  EXPECT_FALSE(crf.validate().ok());
  EXPECT_FALSE(semantic::DenseCrf::create(crf).ok());
  RunConfig c;
  EXPECT_NE(find_config_key("crf.iterations")->parse(c, "101"), "");

  slam::TrackerOptions t;
  t.rgb_boost_condition = 0.5;
  ASSERT_FALSE(t.validate().ok());
  EXPECT_NE(to_string(t.validate().error()).find("rgb_boost_condition"), std::string::npos);
  slam::SurfelSlamOptions s;
  s.prediction.index_map_scale = slam::kMaxIndexScale + 1;
  EXPECT_FALSE(s.validate().ok());
  s.prediction.index_map_scale = slam::kMaxIndexScale;
  EXPECT_TRUE(s.validate().ok());

  // RunConfig::validate() runs them all.
  RunConfig r;
  r.run.out = "out";
  ASSERT_TRUE(r.validate({0}).ok());
  r.pipeline.prepared_slots = 1;
  ASSERT_FALSE(r.validate({0}).ok());
  EXPECT_NE(to_string(r.validate({0}).error()).find("prepared_slots"), std::string::npos);
}

TEST(ConfigKeys, FlagsOfBoolsSetTheOppositeOfTheirDefault) {
  for (const char* path : {"progress", "realtime", "labels.enabled", "crf.final"}) {
    const ConfigKey* k = find_config_key(path);
    ASSERT_NE(k, nullptr) << path;
    ASSERT_TRUE(k->set_flag) << path;
    RunConfig c;
    const bool before = k->get(c).b;
    k->set_flag(c);
    EXPECT_EQ(k->get(c).b, !before) << path;
    k->set_flag(c);
    EXPECT_EQ(k->get(c).b, !before) << path << ": a flag sets, it does not toggle";
  }
}

TEST(RunConfigValidate, RulesBetweenPartsAndTheMachine) {
  RunConfig c;
  Status s = c.validate({0, 1});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(to_string(s.error()).find("--out"), std::string::npos);
  c.run.out = "out";
  EXPECT_TRUE(c.validate({0, 1}).ok());

  c.labels.enabled = false;
  c.crf.every = 500;
  s = c.validate({0, 1});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(to_string(s.error()).find("need labels"), std::string::npos);
  c.crf.every = 0;
  c.labels.final_out = "final";
  EXPECT_FALSE(c.validate({0, 1}).ok());
  c.labels.final_out.clear();
  EXPECT_TRUE(c.validate({0, 1}).ok());

  // Every pinned core that is missing is named at once, with what the machine has.
  c.pipeline.front_cpu = 1;
  c.pipeline.capture_cpu = 5;
  c.pipeline.mapping_cpu = 7;
  s = c.validate({0, 1, 2, 3});
  ASSERT_FALSE(s.ok());
  const std::string msg = to_string(s.error());
  EXPECT_NE(msg.find("pipeline.capture_cpu 5, pipeline.mapping_cpu 7"), std::string::npos) << msg;
  EXPECT_NE(msg.find("cores 0-3"), std::string::npos) << msg;
  EXPECT_EQ(msg.find("front_cpu"), std::string::npos) << msg;
  EXPECT_TRUE(c.validate({0, 1, 5, 7}).ok());

  // A live camera cannot be read twice.
  SourceProbe camera;
  camera.live = true;
  c.labels.final_out = "final";
  EXPECT_FALSE(check_run(c, camera).ok());
  EXPECT_TRUE(check_run(c, SourceProbe{}).ok());
}

TEST(RunConfigDescribe, ReadsAsItsOwnKeys) {
  RunConfig c;
  c.mapping.tracker.rgb_weight = 1.0 / 3.0;
  c.mapping.preprocess.depth_cutoff_m = 3.3f;
  const std::string text = c.describe();
  // The shortest text that reads back exactly, for doubles and for floats.
  EXPECT_NE(text.find("rgb_weight: 0.3333333333333333 "), std::string::npos) << text;
  EXPECT_NE(text.find("depth_cutoff_m: 3.3 "), std::string::npos) << text;
  for (const ConfigKey& k : config_keys()) EXPECT_NE(text.find(k.name() + ":"), std::string::npos) << k.path;
}

}  // namespace
}  // namespace ef::pipeline
