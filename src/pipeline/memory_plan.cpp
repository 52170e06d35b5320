#include "pipeline/memory_plan.h"

#include <algorithm>
#include <cstdio>
#include <iterator>
#include <string>

#include "core/arena.h"
#include "core/frame.h"
#include "core/stage_stats.h"
#include "nn/executor.h"
#include "nn/model_format.h"
#include "nn/planner.h"
#include "pipeline/capture_thread.h"
#include "pipeline/cnn_worker.h"
#include "pipeline/final_labels.h"
#include "pipeline/front_stage.h"
#include "pipeline/map_preview.h"
#include "pipeline/run_report.h"
#include "io/trajectory_io.h"
#include "pipeline/mapping_stage.h"
#include "pipeline/model_paths.h"
#include "pipeline/run_pipeline.h"
#include "pipeline/run_semantics.h"
#include "semantic/dense_crf.h"
#include "semantic/label_fusion.h"
#include "semantic/segmenter.h"
#include "slam/model_prediction.h"
#include "slam/preprocess.h"
#include "slam/spatial_order.h"
#include "slam/surfel_fusion.h"
#include "slam/surfel_pool.h"
#include "slam/tracker.h"

namespace ef::pipeline {

namespace {

using std::size_t;

// Every part's bytes come from its class (a static bytes_for of the same options its create() is
// given); this file only adds them up and says how each is made.

std::string size_text(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

std::string mb_text(size_t bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", static_cast<double>(bytes) / 1e6);
  return buf;
}

}  // namespace

size_t MemoryPlan::bytes_of(const std::string& name) const {
  for (const MemoryPart& p : parts)
    if (p.name == name) return p.bytes;
  return 0;
}

std::string MemoryPlan::table() const {
  size_t name_w = 5;
  for (const MemoryPart& p : parts) name_w = std::max(name_w, p.name.size());
  std::string s;
  char line[256];
  std::snprintf(line, sizeof line, "%-*s %12s %9s  %s\n", int(name_w), "part", "bytes", "MB", "how");
  s += line;
  for (const MemoryPart& p : parts) {
    std::snprintf(line, sizeof line, "%-*s %12zu %9s  ", int(name_w), p.name.c_str(), p.bytes, mb_text(p.bytes).c_str());
    s += line + p.detail + "\n";
  }
  std::snprintf(line, sizeof line, "%-*s %12zu %9s\n", int(name_w), "total", total_bytes, mb_text(total_bytes).c_str());
  s += line;
  std::snprintf(line, sizeof line, "%-*s %12zu %9s  memory.budget_mb\n", int(name_w), "budget", budget_bytes,
                mb_text(budget_bytes).c_str());
  s += line;
  return s;
}

Result<MemoryPlan> plan_memory(const RunConfig& config) {
  EF_ASSIGN_OR_RETURN(const SourceProbe probe, probe_source(config.run.source));
  return plan_memory(config, probe);
}

int64_t crf_nodes(const RunConfig& config, std::size_t other_bytes, std::size_t budget_bytes) {
  const int64_t pool = config.mapping.pool.capacity;
  if (config.crf.capacity > 0) return config.crf.capacity;
  // Bytes per node of crf_options_for_run's sizing (its lattice per node included), from the CRF's
  // own bytes_for at a million nodes (the buffers' alignment, a few hundred bytes, is in the 1 MB kept
  // below).
  constexpr int64_t kProbe = 1'000'000;
  const std::size_t per_node =
      semantic::DenseCrf::bytes_for(crf_options_for_run(config, kProbe)) / static_cast<std::size_t>(kProbe);
  const std::size_t left = budget_bytes > other_bytes ? budget_bytes - other_bytes : 0;
  // Rounding and alignment of the buffers take a few bytes more than per_node x nodes: keep 1 MB.
  const std::size_t fits = left > 1'000'000 ? (left - 1'000'000) / per_node : 0;
  return std::max<int64_t>(kMinCrfNodes, std::min<int64_t>(pool, static_cast<int64_t>(fits)));
}

Result<MemoryPlan> plan_memory(const RunConfig& config, const SourceProbe& probe) {
  MemoryPlan plan;
  const auto add = [&plan](std::string name, size_t bytes, std::string detail) {
    plan.parts.push_back(MemoryPart{std::move(name), bytes, std::move(detail)});
  };
  const int w = config.run.resolution.width, h = config.run.resolution.height;
  const int64_t capacity = config.mapping.pool.capacity;
  const bool labels = config.labels.enabled;
  const std::string frame_what = probe.has_labels ? "colour, depth, labels" : "colour, depth";

  // Frames: a recording's frame at its own size (pipeline/front_stage.h), or the capture ring of a
  // live camera (pipeline/capture_thread.h).
  const std::string note = probe.size_assumed ? " (assumed: no size= in the URI)" : "";
  if (probe.live) {
    const int slots = config.pipeline.capture_slots;
    add("capture ring", CaptureThread::bytes_for(slots, probe.width, probe.height, probe.has_labels),
        std::to_string(slots) + " slots x " + size_text(probe.width, probe.height) + note + " (" + frame_what + ")");
  } else {
    add("source frame", Frame::bytes_for(probe.width, probe.height, probe.has_labels),
        size_text(probe.width, probe.height) + " (" + frame_what + ")");
  }

  if (!config.log.file.empty())
    add("field log", McapFrameLog::bytes_for(config.log, probe.width, probe.height, labels ? w : 0, labels ? h : 0),
        std::to_string(config.log.chunk_mb) + " MB chunk + the front's image encoder (" +
            size_text(probe.width, probe.height) + ")" + (labels ? " + the labels' (" + size_text(w, h) + ")" : ""));

  // SLAM (slam/surfel_slam.h) with the options the mapping stage gives it.
  const slam::SurfelSlamOptions slam = MappingStage::slam_options(config.mapping);
  const int levels = slam.preprocess.levels;
  const int scale = slam.prediction.index_map_scale;
  add("slam tracker", slam::Tracker::bytes_for(w, h, levels, slam.tracker), "row tiles, the SO(3) level's images and rays");
  add("surfel pool", slam::SurfelPool::bytes_for(capacity),
      std::to_string(capacity) + " surfels x " + std::to_string(slam::SurfelPool::kBytesPerSurfel) + " bytes (label store " +
          std::to_string(slam::SurfelPool::kLabelBytesPerSurfel) + " included) + " +
          std::to_string(sizeof(slam::SurfelPool::BlockBounds)) + " bytes of bounds per " +
          std::to_string(slam::SurfelPool::kBoundsBlock) + " surfels");
  add("surfel spatial order", slam::SpatialOrder::bytes_for(capacity),
      "8 bytes x capacity + a " + std::to_string(slam::SpatialOrder::kKeys / 1024 * 4) + " KiB histogram");
  add("model prediction", slam::ModelPredictor::bytes_for(w, h, levels, slam.prediction),
      std::to_string(scale) + "x index map " + size_text(w * scale, h * scale) + " + " + std::to_string(levels) +
          " predicted levels");
  add("keyframe ferns", slam::KeyframeFerns::bytes_for(slam.ferns),
      std::to_string(slam.ferns.capacity) + " keyframes x (" + std::to_string(slam.ferns.ferns) +
          " fern codes + pose + frame), for relocalisation");
  if (slam.loop_closure) {
    const slam::DeformationGraphOptions graph = slam.graph.for_pool(capacity);
    add("deformation graph", slam::DeformationGraph::bytes_for(graph),
        std::to_string(graph.max_nodes) + " nodes (1 per " + std::to_string(graph.surfels_per_node) +
            " surfels), their banded Gauss-Newton system (" + std::to_string(12 * (2 * graph.neighbours + 1)) +
            " wide), " + std::to_string(graph.max_constraints) + " constraints, for loop closure");
    add("pose history", slam::PoseHistory::bytes_for(slam.pose_history),
        std::to_string(slam.pose_history) + " frames x " + std::to_string(slam::PoseHistory::kBytesPerFrame) +
            " bytes: the poses loop closure corrects (trajectory.txt rewritten with them)");
  }
  add("surfel fusion scratch", slam::SurfelFusion::bytes_for(w, h, scale, capacity, slam.fusion),
      "marks per index cell, seen surfels, the lifetime sweep, per-pixel measurements");
  const size_t stages = std::size(MappingStage::kStageNames) + (labels ? std::size(RunSemantics::kStageNames) : 0) +
                        std::size(RunPipeline::kStageNames);
  add("stage statistics", StageStats::bytes_for(stages),
      std::to_string(stages) + " stages + 1 scratch x " + std::to_string(StageStats::kDefaultCapacity) + " samples");

  size_t cnn_result = 0;  // one frame's CNN probabilities and class ids (CnnResult)
  if (labels) {
    const std::string model_path = RunSemantics::model_path(config.labels, config.run.source);
    EF_RETURN_IF_ERROR(check_model_file(model_path, config.labels.model.empty()));
    EF_ASSIGN_OR_RETURN(nn::Model model, nn::load_model(model_path));
    const nn::ModelDesc& d = model.desc;
    const nn::TensorDesc& in = d.tensors[d.input_tensor];
    const nn::TensorDesc& out = d.tensors[d.output_tensor];
    add("cnn model", model.bytes(), "weights and prepared copies of " + model_path);
    EF_ASSIGN_OR_RETURN(nn::MemoryPlan arena, nn::plan_memory(model));
    add("cnn arena", std::max<size_t>(arena.total_bytes, Arena::kMaxAlign),
        "activations, liveness-planned (nn/planner.h), " + std::to_string(d.layers.size()) + " layers");
    add("cnn packed weights", nn::Executor::packed_bytes_for(model), "convolution weights in this CPU's kernel layout");
    add("segmenter buffers", semantic::Segmenter::buffer_bytes_for(model, w, h),
        "input " + size_text(int(in.w), int(in.h)) + ", output " + size_text(int(out.w), int(out.h)) + " x " +
            std::to_string(out.c) + " classes");
    const SemanticsOptions sem = semantics_options(config);
    add("label fusion", semantic::LabelFusion::bytes_for(RunSemantics::fusion_options(sem, w, h, int(out.w), int(out.h))),
        "16 bytes per CNN pixel + a pair per index cell at the largest scale (" +
            std::to_string(slam::kMaxIndexScale) + "x)");
    const int classes = semantic::Segmenter::classes_for(model);  // after the model's class map
    cnn_result = CnnResult::bytes_for(int(out.w), int(out.h), classes, w, h);
    add("cnn jobs", size_t(CnnWorker::kJobs) * CnnJob::bytes_for(w, h, cnn_result),
        std::to_string(CnnWorker::kJobs) + " x (working frame " + size_text(w, h) + " without labels + CNN result " +
            size_text(int(out.w), int(out.h)) + " x " + std::to_string(classes) + " floats + class ids)");
    add("late label fusion", RunSemantics::late_fusion_bytes_for(w, h, slam.prediction),
        "an index map renderer for CNN results that finish after their frame, " +
            std::to_string(RunSemantics::kPoseHistory) + " poses");
    add("label rendering", RunSemantics::rendering_bytes_for(w, h), "the map's labels, " + size_text(w, h) + " x 1 byte");
    add("map.ply class columns", RunSemantics::class_column_bytes_for(sem.pool_capacity),
        "5 bytes (class id, probability) x capacity");
    if (!config.labels.final_out.empty()) {
      add("final label pass",
          FinalLabelBuffers::bytes_for(config.run, probe.width, probe.height, probe.has_labels,
                                       slam::ModelPredictor::bytes_for(w, h, levels, slam.prediction), cnn_result),
          "after the run: frames at " + size_text(probe.width, probe.height) + " and " + size_text(w, h) +
              ", a CNN result, a predictor of the whole map, the rendering");
    }
  }

  if (config.run.report)
    add("run report", kReportRateSamples * sizeof(RateSample) + kReportReferencePoses * sizeof(TimedPose),
        std::to_string(kReportRateSamples) + " rate samples + " + std::to_string(kReportReferencePoses) +
            " reference poses, kept while mapping for report.html (pipeline/run_report.h)");
  if (config.run.preview || config.run.report)
    add("map preview", map_preview_bytes_for(kPreviewWidth, kPreviewHeight),
        "from the start: preview.png at each checkpoint and at the end, two " + size_text(kPreviewWidth, kPreviewHeight) +
            " panels, their depth buffer, the camera's path, the PNG encoder (pipeline/map_preview.h)");

  // Prepared frames (pipeline/front_stage.h): per slot the working frame and its preprocessor.
  const int slots = config.pipeline.slots();
  add("prepared frames",
      size_t(slots) * PreparedFrame::bytes_for(w, h, probe.has_labels, slam::Preprocessor::bytes_for(w, h, slam.preprocess)),
      std::to_string(slots) + " slots x (working frame " + size_text(w, h) + " + pyramids)");

  plan.budget_bytes = static_cast<size_t>(config.memory.budget_mb) * 1'000'000;
  // The dense CRF last: with crf.capacity 0 it takes what the budget leaves (at most the pool).
  if (config.labels.enabled && config.crf.on()) {
    std::size_t others = 0;
    for (const MemoryPart& p : plan.parts) others += p.bytes;
    plan.crf_nodes = crf_nodes(config, others, plan.budget_bytes);
    const semantic::DenseCrfOptions co = crf_options_for_run(config, plan.crf_nodes);
    add("dense crf", semantic::DenseCrf::bytes_for(co),
        std::to_string(co.capacity) + " surfels x " + std::to_string(semantic::DenseCrf::kBytesPerSurfel) + " + " +
            std::to_string(co.lattice_vertices()) + " lattice vertices x about " +
            std::to_string(semantic::DenseCrf::kBytesPerVertex) + " (semantic/dense_crf.h)" +
            (config.crf.capacity > 0 ? std::string(" (crf.capacity)")
             : co.capacity < config.mapping.pool.capacity
                 ? std::string(" (crf.capacity 0: what the budget leaves, fewer than the pool's ") +
                       std::to_string(config.mapping.pool.capacity) + ")"
                 : std::string(" (crf.capacity 0: the pool's)")));
  }
  for (const MemoryPart& p : plan.parts) plan.total_bytes += p.bytes;
  return plan;
}

Result<MemoryPlan> check_and_plan(const RunConfig& config, const SourceProbe& probe) {
  EF_RETURN_IF_ERROR(config.validate());
  EF_RETURN_IF_ERROR(check_run(config, probe));
  return plan_memory(config, probe);
}

Status check_memory_budget(const RunConfig& config) {
  EF_ASSIGN_OR_RETURN(MemoryPlan plan, plan_memory(config));
  return check_memory_budget(plan, config);
}

Status check_memory_budget(const MemoryPlan& plan, const RunConfig& config) {
  if (plan.within_budget()) return Status::success();
  std::vector<MemoryPart> largest = plan.parts;
  std::sort(largest.begin(), largest.end(), [](const MemoryPart& a, const MemoryPart& b) { return a.bytes > b.bytes; });
  std::string parts;
  for (size_t i = 0; i < largest.size() && i < 3; ++i)
    parts += (i ? ", " : "") + largest[i].name + " " + mb_text(largest[i].bytes) + " MB";
  return error(ErrorCode::kResourceExhausted,
               "memory plan: " + mb_text(plan.total_bytes) + " MB exceeds the budget of " +
                   std::to_string(config.memory.budget_mb) + " MB (memory.budget_mb); largest parts: " + parts +
                   ". Lower mapping.surfel_capacity (or the resolution, or turn the CRF off) or raise "
                   "memory.budget_mb; `edgefusion plan` with the same options lists every part");
}

}  // namespace ef::pipeline
