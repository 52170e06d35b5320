// The memory plan (pipeline/memory_plan.h): every part from its class's bytes_for(), checked against
// what the objects really allocate when `run` creates them, against the budget, and against the
// documented figures (docs/architecture.md, memory budget).
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "core/intrinsics.h"
#include "core/stage_stats.h"
#include "pipeline/final_labels.h"
#include "pipeline/memory_plan.h"
#include "pipeline/model_paths.h"
#include "pipeline/run_config.h"
#include "pipeline/run_pipeline.h"
#include "pipeline/run_semantics.h"
#include "semantic/dense_crf.h"
#include "semantic/segmenter.h"
#include "slam/surfel_fusion.h"
#include "slam/surfel_slam.h"
#include "sources/open_source.h"
#include "test_support.h"

namespace ef::pipeline {
namespace {

namespace fs = std::filesystem;

// A configuration small enough to create every object for real, also under qemu.
RunConfig small_config() {
  RunConfig c;
  c.run.source = "synthetic:?size=320x240";
  c.run.resolution.width = 160;
  c.run.resolution.height = 120;
  c.mapping.pool.capacity = 20000;
  c.crf.final = true;
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
  for (const char* part : {"source frame", "prepared frames", "slam tracker", "surfel pool", "surfel spatial order", "keyframe ferns",
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
    with_pass.labels.final_out = "final";
    auto pf = plan_memory(with_pass);
    ASSERT_TRUE(pf.ok()) << to_string(pf.error());
    EXPECT_NEAR(double(pf->bytes_of("final label pass")), 10.7e6, 0.1e6);
    EXPECT_EQ(pf->total_bytes - plan->total_bytes, pf->bytes_of("final label pass"));
  }
  // docs/architecture.md, memory budget: 60 bytes per surfel and 32 bytes of bounds per 256 of them
  // (3907 blocks); 640x480 x 8 source frame; the 1x index map (24 bytes per cell) 1.8 MB of the 6.4 MB
  // of prediction at 320x240; fusion scratch 1.1 MB; spatial order 9.0 MB.
  EXPECT_NEAR(double(plan->bytes_of("surfel pool")), 60e6 + 3907 * 32, 1e3);
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
    fine.mapping.prediction.index_map_scale = 4;
    auto p4 = plan_memory(fine);
    ASSERT_TRUE(p4.ok()) << to_string(p4.error());
    EXPECT_EQ(p4->bytes_of("model prediction") - plan->bytes_of("model prediction"), (1280u * 960 - 320u * 240) * 24);
    EXPECT_NEAR(double(p4->bytes_of("surfel fusion scratch")), 5.9e6, 0.1e6);
  }

  // Geometry only: no segmenter parts, no model file needed.
  c.labels.enabled = false;
  c.labels.model = "/nonexistent/model.efm";
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

  const Intrinsics working = Intrinsics{525.f, 525.f, 319.5f, 239.5f, 640, 480}.scaled_to(c.run.resolution.width, c.run.resolution.height);
  slam::SurfelSlamOptions so;
  so.pool.capacity = c.mapping.pool.capacity;
  auto slam = slam::SurfelSlam::create(working, so);
  ASSERT_TRUE(slam.ok()) << to_string(slam.error());
  EXPECT_EQ(plan->bytes_of("surfel pool"), slam->pool_bytes());
  EXPECT_EQ(plan->bytes_of("surfel spatial order"), slam->spatial_order_bytes());
  EXPECT_EQ(plan->bytes_of("keyframe ferns"), slam->keyframe_bytes());
  EXPECT_EQ(plan->bytes_of("deformation graph"), slam->deformation_bytes());
  EXPECT_EQ(plan->bytes_of("pose history"), slam->pose_history_bytes());
  EXPECT_GT(slam->pose_history_bytes(), 0u);
  EXPECT_EQ(plan->bytes_of("model prediction"), slam->predictor().bytes());
  auto fusion = slam::SurfelFusion::create(working, so.prediction.index_map_scale, c.mapping.pool.capacity, so.fusion);
  ASSERT_TRUE(fusion.ok());
  EXPECT_EQ(plan->bytes_of("surfel fusion scratch"), fusion->bytes());

  auto seg = semantic::Segmenter::create(default_model_path(c.run.source));
  ASSERT_TRUE(seg.ok()) << to_string(seg.error());
  EXPECT_EQ(plan->bytes_of("segmenter buffers"), (*seg)->buffer_bytes());
  EXPECT_EQ(plan->bytes_of("cnn arena"), (*seg)->executor().arena_bytes());
  EXPECT_GE(plan->bytes_of("cnn packed weights"), (*seg)->executor().packed_bytes());
  EXPECT_LE(plan->bytes_of("cnn packed weights"), (*seg)->executor().packed_bytes() + 64);

  // The pipeline's prepared slots and the SLAM's preprocessor, as `run` creates them.
  RunConfig with_out = c;
  with_out.run.out = test::scratch_dir("plan-pipeline").string();
  auto source = open_source(c.run.source);
  ASSERT_TRUE(source.ok());
  StageStats stats;
  auto pipeline = RunPipeline::create(with_out, **source, stats);
  ASSERT_TRUE(pipeline.ok()) << to_string(pipeline.error());
  EXPECT_EQ(plan->bytes_of("prepared frames"), static_cast<std::size_t>(c.pipeline.prepared_slots) * (*pipeline)->slot_bytes());
  EXPECT_EQ(plan->bytes_of("slam preprocessing"), 0u);  // run's SLAM has none of its own
  // Every stage the pipeline registered (mapping and semantics), and its label fusion's buffers.
  EXPECT_EQ(plan->bytes_of("stage statistics"), stats.bytes());
  ASSERT_NE((*pipeline)->semantics(), nullptr);
  EXPECT_EQ(plan->bytes_of("label fusion"), (*pipeline)->semantics()->fusion().bytes());
  EXPECT_EQ(plan->bytes_of("cnn jobs"), (*pipeline)->cnn_job_bytes());
  EXPECT_EQ(plan->bytes_of("late label fusion"), (*pipeline)->semantics()->late_fusion_bytes());

  auto crf = semantic::DenseCrf::create(crf_options_for_run(c, plan->crf_nodes));  // the options `run` creates it with
  ASSERT_TRUE(crf.ok()) << to_string(crf.error());
  EXPECT_EQ(plan->bytes_of("dense crf"), crf->bytes()) << plan->table();

  // The final label pass (src/pipeline/final_labels.h) over this run's map, after the run.
  RunConfig with_final = c;
  with_final.labels.final_out = (fs::path(with_out.run.out) / "final").string();
  auto final_plan = plan_memory(with_final);
  ASSERT_TRUE(final_plan.ok()) << to_string(final_plan.error());
  EXPECT_EQ(plan->bytes_of("final label pass"), 0u);  // only planned when asked for
  StageStats semantic_stats;
  auto semantics = RunSemantics::create(semantics_options(with_final), working, semantic_stats);
  ASSERT_TRUE(semantics.ok()) << to_string(semantics.error());
  auto final_pass = FinalLabelBuffers::create(with_final.run, (*source)->info(), *slam, **semantics);
  ASSERT_TRUE(final_pass.ok()) << to_string(final_pass.error());
  EXPECT_EQ(final_plan->bytes_of("final label pass"), final_pass->bytes()) << final_plan->table();
}

// Issue 28: the real-camera model (RGB, 151 classes mapped to 14 inside the model, its CNN beside
// the pipeline): every part the plan names is what the run allocates.
TEST(PlanMemory, RealCameraModelPartsAreWhatTheRunAllocates) {
  RunConfig c;
  c.run.source = "synthetic:?frames=3&size=320x240";
  c.run.progress = false;
  c.labels.model = std::string(EF_SOURCE_DIR) + "/models/" + kRealModelFile;
  c.run.out = test::scratch_dir("plan-real-model").string();
  auto plan = plan_memory(c);
  ASSERT_TRUE(plan.ok()) << to_string(plan.error());
  auto source = open_source(c.run.source);
  ASSERT_TRUE(source.ok());
  StageStats stats;
  auto pipeline = RunPipeline::create(c, **source, stats);
  ASSERT_TRUE(pipeline.ok()) << to_string(pipeline.error());
  const RunSemantics* sem = (*pipeline)->semantics();
  ASSERT_NE(sem, nullptr);
  EXPECT_EQ(sem->segmenter().num_classes(), 14);
  EXPECT_EQ(sem->segmenter().model().desc.tensors[sem->segmenter().model().desc.output_tensor].c, 151u);
  EXPECT_EQ(plan->bytes_of("cnn model"), sem->segmenter().model().bytes());
  EXPECT_EQ(plan->bytes_of("segmenter buffers"), sem->segmenter().buffer_bytes());
  EXPECT_EQ(plan->bytes_of("cnn arena"), sem->segmenter().executor().arena_bytes());
  EXPECT_EQ(plan->bytes_of("label fusion"), sem->fusion().bytes());
  EXPECT_EQ(plan->bytes_of("cnn jobs"), (*pipeline)->cnn_job_bytes()) << plan->table();
  EXPECT_EQ(plan->bytes_of("late label fusion"), sem->late_fusion_bytes());
}

TEST(PlanMemory, OverBudgetIsRefusedWithTheNumbers) {
  RunConfig c;
  c.mapping.pool.capacity = 2'000'000;
  c.crf.final = true;
  c.crf.capacity = 2'000'000;  // 2M x (60 + 588 + 5) bytes alone is 1.3 GB
  auto plan = plan_memory(c);
  ASSERT_TRUE(plan.ok()) << to_string(plan.error());
  EXPECT_FALSE(plan->within_budget());
  const Status s = check_memory_budget(c);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kResourceExhausted);
  const std::string msg = to_string(s.error());
  for (const char* e : {"256 MB", "memory.budget_mb", "dense crf", "surfel pool", "surfel_capacity"})
    EXPECT_NE(msg.find(e), std::string::npos) << e << " in " << msg;

  c.memory.budget_mb = 2000;
  EXPECT_TRUE(check_memory_budget(c).ok());
  c.memory.budget_mb = 256;
  // crf.capacity 0 (derived): the CRF takes what the budget leaves, fewer surfels than the pool.
  c.crf.capacity = 0;
  c.mapping.pool.capacity = 1'000'000;
  auto derived = plan_memory(c);
  ASSERT_TRUE(derived.ok()) << to_string(derived.error());
  EXPECT_TRUE(derived->within_budget()) << derived->table();
  EXPECT_GT(derived->total_bytes, derived->budget_bytes - 2'000'000) << derived->table();  // and uses it
  EXPECT_GT(derived->crf_nodes, 100'000);
  EXPECT_LT(derived->crf_nodes, 1'000'000);
  EXPECT_NE(derived->table().find("what the budget leaves"), std::string::npos) << derived->table();
  // With room for all of it, the pool's capacity; with a budget too small for the rest, over budget.
  c.memory.budget_mb = 2000;
  auto roomy = plan_memory(c);
  ASSERT_TRUE(roomy.ok());
  EXPECT_EQ(roomy->crf_nodes, 1'000'000);
  c.memory.budget_mb = 60;
  auto tight = plan_memory(c);
  ASSERT_TRUE(tight.ok());
  EXPECT_EQ(tight->crf_nodes, kMinCrfNodes);
  EXPECT_FALSE(tight->within_budget());
  c.memory.budget_mb = 256;
  c.crf.final = false;
  c.mapping.pool.capacity = 1'000'000;
  EXPECT_TRUE(check_memory_budget(c).ok());

  c.labels.model = "/nonexistent/model.efm";
  const Status m = check_memory_budget(c);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(to_string(m.error()).find("/nonexistent/model.efm"), std::string::npos);
}

// A live camera is planned from its URI alone (the device is not touched): its requested size, a
// capture ring of pipeline.capture_slots frames.
TEST(PlanMemory, LiveCameraFromItsUri) {
  RunConfig c;
  c.labels.enabled = false;
  c.run.source = "openni2:?size=320x240";
  auto probe = probe_source(c.run.source);
  if (!probe.ok() && probe.error().code == ErrorCode::kUnsupported) GTEST_SKIP() << to_string(probe.error());
  ASSERT_TRUE(probe.ok()) << to_string(probe.error());
  EXPECT_TRUE(probe->live);
  EXPECT_FALSE(probe->size_assumed);
  auto plan = plan_memory(c, *probe);
  ASSERT_TRUE(plan.ok()) << to_string(plan.error());
  EXPECT_EQ(plan->bytes_of("capture ring"), 4u * 320 * 240 * 7);  // colour + depth, no labels
  EXPECT_EQ(plan->bytes_of("source frame"), 0u);
  // Without size= the camera is asked for 640x480, and the plan says it assumed so.
  probe = probe_source("openni2:");
  ASSERT_TRUE(probe.ok()) << to_string(probe.error());
  EXPECT_TRUE(probe->size_assumed);
  EXPECT_EQ(probe->width, 640);
  plan = plan_memory(c, *probe);
  ASSERT_TRUE(plan.ok());
  EXPECT_NE(plan->table().find("assumed"), std::string::npos) << plan->table();
  // A bad query is refused as opening the camera would refuse it.
  probe = probe_source("openni2:?sise=320x240");
  ASSERT_FALSE(probe.ok());
  EXPECT_NE(to_string(probe.error()).find("sise"), std::string::npos) << to_string(probe.error());
}

}  // namespace
}  // namespace ef::pipeline
