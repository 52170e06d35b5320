// Stage statistics (median / p95 in ms, reservoir, counters) and the stats.json text.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <iterator>
#include <limits>
#include <thread>

#include "core/stage_stats.h"
#include "io/stats_json.h"
#include "test_support.h"

namespace ef {
namespace {

TEST(OutputsStageStats, MedianAndP95OfKnownSamples) {
  StageStats st(200);
  const int a = st.add_stage("track");
  ASSERT_EQ(a, 0);
  EXPECT_EQ(st.add_stage("track"), 0);  // same name, same id
  // 1..100 ms shuffled: median (50 + 51) / 2; p95 at position 0.95 * 99 = 94.05 -> 95 + 0.05 = 95.05.
  for (int i = 0; i < 100; ++i) st.record_ms(a, 1 + (i * 37) % 100);
  const StageSummary s = st.summary(a);
  EXPECT_EQ(s.count, 100u);
  EXPECT_DOUBLE_EQ(s.median_ms, 50.5);
  EXPECT_NEAR(s.p95_ms, 95.05, 1e-9);
  EXPECT_DOUBLE_EQ(s.mean_ms, 50.5);
  EXPECT_DOUBLE_EQ(s.max_ms, 100.0);
  EXPECT_DOUBLE_EQ(s.total_ms, 5050.0);
  st.record_ns(a, 2'500'000);  // 2.5 ms
  EXPECT_EQ(st.summary(a).count, 101u);
  EXPECT_EQ(st.summary(st.add_stage("idle")).count, 0u);
  EXPECT_EQ(st.summary(st.add_stage("idle")).median_ms, 0.0);
}

TEST(OutputsStageStats, ReservoirKeepsExactCountMeanAndMax) {
  StageStats st(16);
  const int a = st.add_stage("fuse");
  for (int i = 1; i <= 1000; ++i) st.record_ms(a, i);
  const StageSummary s = st.summary(a);
  EXPECT_EQ(s.count, 1000u);
  EXPECT_DOUBLE_EQ(s.max_ms, 1000.0);
  EXPECT_DOUBLE_EQ(s.mean_ms, 500.5);
  EXPECT_GE(s.median_ms, 1.0);
  EXPECT_LE(s.p95_ms, 1000.0);
  EXPECT_LE(s.median_ms, s.p95_ms);
  // A uniform sample of 16 from 1..1000 has its median far from the first 16 values (1..16):
  // the reservoir did replace samples.
  EXPECT_GT(s.median_ms, 16.0);
}

TEST(OutputsStageStats, CountersAndLimits) {
  StageStats st(4, 2, 2);
  const int c0 = st.add_counter("frames_dropped");
  const int c1 = st.add_counter("relocalisations");
  EXPECT_EQ(st.add_counter("third"), -1);  // fixed maximum
  EXPECT_EQ(st.add_stage("s0"), 0);
  EXPECT_EQ(st.add_stage("s1"), 1);
  EXPECT_EQ(st.add_stage("s2"), -1);
  st.increment(c0);
  st.increment(c0, 4);
  st.increment(-1);  // ignored
  st.set_counter(c1, 9);
  EXPECT_EQ(st.counter(c0), 5u);
  EXPECT_EQ(st.counter(c1), 9u);
  EXPECT_EQ(st.counter_id("relocalisations"), 1);
  EXPECT_EQ(st.counter_id("nope"), -1);
  st.record_ms(7, 1.0);  // ignored, no crash
  st.reset();
  EXPECT_EQ(st.counter(c0), 0u);
  EXPECT_EQ(st.num_counters(), 2u);
}

TEST(OutputsStageStats, ScopedTimerMeasuresSteadyClock) {
  StageStats st(8);
  const int a = st.add_stage("sleep");
  {
    ScopedStageTimer t(st, a);
    std::this_thread::sleep_for(std::chrono::milliseconds(3));
  }
  {
    ScopedStageTimer t(st, a);
    t.cancel();
  }
  const StageSummary s = st.summary(a);
  ASSERT_EQ(s.count, 1u);
  EXPECT_GE(s.median_ms, 3.0);
  EXPECT_LT(s.median_ms, 1000.0);
}

TEST(OutputsStatsJson, ExactText) {
  StageStats st(64);
  const int a = st.add_stage("track");
  st.add_stage("cnn");
  const int c = st.add_counter("quote\"back\\slash\n");
  // 0..20 ms: median 10, p95 at position 19 exactly, mean 10, max 20.
  for (int i = 20; i >= 0; --i) st.record_ms(a, i);
  st.increment(c, 3);
  const std::string json = stats_to_json(st, 100, 4.0, {{"dropped_frames", 2}, {"peak_rss_bytes", 123456789012.0}});
  EXPECT_EQ(json,
            "{\"frames\":100,\"seconds\":4,\"fps\":25,\"dropped_frames\":2,\"peak_rss_bytes\":123456789012,"
            "\"stages\":{\"track\":{\"median_ms\":10,\"p95_ms\":19,\"mean_ms\":10,\"max_ms\":20,\"count\":21},"
            "\"cnn\":{\"median_ms\":0,\"p95_ms\":0,\"mean_ms\":0,\"max_ms\":0,\"count\":0}},"
            "\"counters\":{\"quote\\\"back\\\\slash\\n\":3}}\n");
}

TEST(OutputsStatsJson, NumbersAndEscapes) {
  JsonWriter w;
  w.begin_object();
  w.key("a");
  w.value(0.1);
  w.key("b");
  w.value(1.0 / 3.0);
  w.key("c");
  w.value(std::numeric_limits<double>::quiet_NaN());
  w.key(std::string_view("\x01\t\xc3\xa9", 4));
  w.value(std::string_view("x"));
  w.key("e");
  w.begin_object();
  w.end_object();
  w.key("f");
  w.value(-7);
  w.end_object();
  EXPECT_EQ(w.str(), "{\"a\":0.1,\"b\":0.3333333333333333,\"c\":null,\"\\u0001\\t\xc3\xa9\":\"x\",\"e\":{},\"f\":-7}");
}

TEST(OutputsStatsJson, WritesFileAndZeroSeconds) {
  StageStats st(4);
  const std::string path = (test::scratch_dir("stats_json") / "stats.json").string();
  ASSERT_TRUE(write_stats_json(path, st, 0, 0.0).ok());
  std::ifstream in(path);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_EQ(text, "{\"frames\":0,\"seconds\":0,\"fps\":0,\"stages\":{},\"counters\":{}}\n");
  EXPECT_FALSE(write_stats_json("/nonexistent-dir/x/stats.json", st, 0, 0.0).ok());
}

}  // namespace
}  // namespace ef
