#include "pipeline/memory_plan.h"

#include "pipeline/mapping_stage.h"
#include "pipeline/run_semantics.h"

#include <algorithm>
#include <cstdio>
#include <string>

#include "core/arena.h"
#include "core/image.h"
#include "io/frame_source.h"
#include "sources/open_source.h"
#include "kernels/label_update.h"
#include "pipeline/model_paths.h"
#include "pipeline/run_semantics.h"
#include "nn/conv_kernels.h"
#include "nn/model_format.h"
#include "nn/planner.h"
#include "semantic/dense_crf.h"
#include "semantic/label_store.h"
#include "slam/model_prediction.h"
#include "slam/preprocess.h"
#include "slam/spatial_order.h"
#include "slam/surfel_fusion.h"
#include "slam/spatial_order.h"
#include "slam/surfel_pool.h"
#include "slam/tracker.h"

namespace ef::pipeline {

namespace {

using std::size_t;

// Formulas below restate what each class's create() allocates, with the constants of its header.
// Those marked "(from the .cpp)" use a number that only the class's .cpp knows; they belong in a
// static bytes_for(...) of the class (see the report of issue 7).

constexpr size_t kFrameBytesPerPixel = sizeof(Rgb8) + sizeof(float) + sizeof(uint8_t);  // colour, depth, labels
constexpr int kStageSamples = 4096;         // StageStats' default reservoir per stage (core/stage_stats.h)
constexpr int kRunStages = 9;  // source, resample, preprocess, front_total, track, fuse, predict, slam_total, mapping_total
constexpr int kLabelStages = 4;             // segment, label_fuse, label_render, crf (run_semantics)
constexpr int kLabelFusionIndexScale = 4;   // LabelFusion sizes its pair list for the largest index scale

size_t round64(size_t n) { return (n + 63) / 64 * 64; }
size_t px(int w, int h) { return static_cast<size_t>(w) * static_cast<size_t>(h); }
std::string size_text(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

// Bytes of a loaded model's arrays (weights and their prepared copies, biases, tables).
size_t model_bytes(const nn::Model& m) {
  size_t b = 0;
  for (const nn::LayerDesc& l : m.desc.layers)
    b += l.weights.size() + l.bias.size() * sizeof(int32_t) + l.weight_scales.size() * sizeof(float);
  for (const nn::PreparedLayer& p : m.prepared)
    b += p.requant.size() * sizeof(nn::Requant) + p.packed.size() + p.bias.size() * sizeof(int32_t) +
         p.exp_table.size() * sizeof(float);
  b += m.desc.tensors.size() * sizeof(nn::TensorDesc) + m.desc.layers.size() * sizeof(nn::LayerDesc);
  return b;
}

// What nn::Executor::pack_weights() allocates: one arena of 64-byte aligned blobs, one per
// convolution, in the layout of the variant this CPU runs (nn/conv_kernels.h).
size_t packed_weight_bytes(const nn::Model& m) {
  const nn::ModelDesc& d = m.desc;
  size_t total = Arena::kMaxAlign;
  for (const nn::LayerDesc& l : d.layers) {
    if (l.type != nn::LayerType::kConv2d && l.type != nn::LayerType::kDepthwiseConv2d &&
        l.type != nn::LayerType::kPointwiseConv2d)
      continue;
    const auto& variant =
        l.type == nn::LayerType::kDepthwiseConv2d ? nn::dwconv_i8_selected() : nn::conv_i8_selected();
    const nn::TensorDesc& in = d.tensors[l.inputs[0]];
    const nn::TensorDesc& out = d.tensors[l.output];
    const nn::ConvShape shape{int(in.c), int(out.c), int(l.kernel_h), int(l.kernel_w), in.zero_point};
    total += round64(variant.fn->packed_bytes(shape));
  }
  return total;
}

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
  EF_ASSIGN_OR_RETURN(const SourceProbe probe, probe_source(config.source));
  return plan_memory(config, probe);
}

Result<MemoryPlan> plan_memory(const RunConfig& config, const SourceProbe& probe) {
  MemoryPlan plan;
  const auto add = [&plan](std::string name, size_t bytes, std::string detail) {
    plan.parts.push_back(MemoryPart{std::move(name), bytes, std::move(detail)});
  };
  const int w = config.width, h = config.height;
  const auto cap = static_cast<size_t>(config.surfel_capacity);

  // Frames (pipeline/run_pipeline.h): a recording's frame at its own size, or the capture ring
  // of a live camera; colour + depth + labels.
  const std::string note = probe.size_assumed ? " (assumed: no size= in the URI)" : "";
  struct {
    int w, h;
  } const src{probe.width, probe.height};
  const bool live = probe.live;
  const size_t source_frames = live ? static_cast<size_t>(config.capture_slots) : 1;
  add(live ? "capture ring" : "source frame", source_frames * px(src.w, src.h) * kFrameBytesPerPixel,
      (live ? std::to_string(source_frames) + " slots x " : std::string()) + size_text(src.w, src.h) + note +
          " x 8 bytes (colour, depth, labels)");

  // SLAM (slam/surfel_slam.h) with the options `run` gives it.
  const slam::SurfelSlamOptions slam = slam_options(config);
  const slam::PreprocessOptions& pre = slam.preprocess;
  const slam::PredictionOptions& pred = slam.prediction;
  const slam::FusionOptions& fus = slam.fusion;
  const slam::TrackerOptions& trk = slam.tracker;
  const int levels = pre.levels;
  // One preprocessor per prepared frame (below); not a part of its own: `run`'s SLAM has none
  // (own_preprocessor = false).
  const size_t preprocessor_bytes = slam::Preprocessor::bytes_for(w, h, pre);
  add("slam tracker", slam::Tracker::bytes_for(w, h, levels, trk), "row tiles, the SO(3) level's images and rays");
  add("surfel pool", slam::SurfelPool::bytes_for(config.surfel_capacity),
      std::to_string(cap) + " surfels x " + std::to_string(slam::SurfelPool::kBytesPerSurfel) + " bytes (label store " +
          std::to_string(slam::SurfelPool::kLabelBytesPerSurfel) + " included)");
  add("surfel spatial order", slam::SpatialOrder::bytes_for(static_cast<int64_t>(cap)),
      "8 bytes x capacity + a " + std::to_string(slam::SpatialOrder::kKeys / 1024 * 4) +
          " KiB histogram (slam/spatial_order.h)");
  {
    const int s = pred.index_map_scale;
    add("model prediction", slam::ModelPredictor::bytes_for(w, h, levels, pred),
        std::to_string(s) + "x index map " + size_text(w * s, h * s) + " x 24 bytes + " + std::to_string(levels) +
            " predicted levels");
  }
  add("surfel fusion scratch", slam::SurfelFusion::bytes_for(w, h, pred.index_map_scale, config.surfel_capacity, fus),
      "1 byte per index cell + 4 bytes x (min(capacity, index cells) + sweep + 2 x working pixels + 24 x working width)");
  const int stages = kRunStages + (config.labels ? kLabelStages : 0);
  add("stage statistics", static_cast<size_t>(stages + 1) * kStageSamples * sizeof(double),
      std::to_string(stages) + " stages + 1 scratch x " + std::to_string(kStageSamples) + " samples x 8 bytes");

  size_t cnn_result = 0;  // one frame's CNN probabilities and class ids (pipeline/run_semantics.h)
  if (config.labels) {
    const bool default_model = config.model.empty();
    const std::string model_path = default_model ? default_model_path() : config.model;
    EF_RETURN_IF_ERROR(check_model_file(model_path, default_model));
    EF_ASSIGN_OR_RETURN(nn::Model model, nn::load_model(model_path));
    const nn::ModelDesc& d = model.desc;
    const nn::TensorDesc& in = d.tensors[d.input_tensor];
    const nn::TensorDesc& out = d.tensors[d.output_tensor];
    const int in_w = int(in.w), in_h = int(in.h), out_w = int(out.w), out_h = int(out.h), classes = int(out.c);
    add("cnn model", model_bytes(model), "weights and prepared copies of " + model_path);
    EF_ASSIGN_OR_RETURN(nn::MemoryPlan arena, nn::plan_memory(model));
    add("cnn arena", std::max<size_t>(arena.total_bytes, Arena::kMaxAlign),
        "activations, liveness-planned (nn/planner.h), " + std::to_string(d.layers.size()) + " layers");
    add("cnn packed weights", packed_weight_bytes(model), "convolution weights in this CPU's kernel layout");
    // semantic/segmenter.h buffer_bytes(): resampled frame (colour + depth), depth-only frame, float
    // input (4 channels), probabilities, class ids.
    const size_t in_px = px(in_w, in_h), out_px = px(out_w, out_h);
    add("segmenter buffers",
        in_px * (sizeof(Rgb8) + 2 * sizeof(float)) + in_px * 4 * sizeof(float) +
            out_px * static_cast<size_t>(classes) * sizeof(float) + out_px,
        "input " + size_text(in_w, in_h) + ", output " + size_text(out_w, out_h) + " x " + std::to_string(classes) +
            " classes");
    // semantic/label_fusion.h: observations (16 bytes per CNN pixel), column table, pair list.
    add("label fusion",
        out_px * semantic::kLabelBytes + static_cast<size_t>(w) * kLabelFusionIndexScale * sizeof(int32_t) +
            px(w, h) * kLabelFusionIndexScale * kLabelFusionIndexScale * sizeof(kernels::LabelUpdatePair),
        "16 bytes per CNN pixel + 16 pairs x 8 bytes per working pixel");
    cnn_result = out_px * static_cast<size_t>(classes) * sizeof(float) + px(w, h);
    add("label rendering", px(w, h), "the map's labels, " + size_text(w, h) + " x 1 byte");
    add("map.ply class columns", cap * (sizeof(uint8_t) + sizeof(float)), "5 bytes (class id, probability) x capacity");
    if (!config.labels_final_out.empty()) {
      // pipeline/final_labels.h, after the run: a source frame, a working frame, a CNN result,
      // a predictor of the whole map (its size does not depend on the time window it drops) and the
      // rendered image, beside everything the run holds.
      add("final label pass",
          px(src.w, src.h) * kFrameBytesPerPixel + px(w, h) * kFrameBytesPerPixel +
              out_px * static_cast<size_t>(classes) * sizeof(float) + px(w, h) +
              slam::ModelPredictor::bytes_for(w, h, levels, pred) + px(w, h),
          "after the run: frames at " + size_text(src.w, src.h) + " and " + size_text(w, h) +
              ", a CNN result, a predictor of the whole map, the rendering");
    }
    if (config.crf_every > 0 || config.crf_final) {
      // semantic/dense_crf.h: capacity x kBytesPerSurfel + lattice vertices x kBytesPerVertex, where
      // the vertex part is two lattices (PermutohedralLattice::create: points, vertices and one spare
      // value row) and two splat buffers of PermutohedralLattice::scratch_floats() (the hash table).
      using semantic::PermutohedralLattice;
      const semantic::DenseCrfOptions co = run_crf_options(config);
      const int64_t vertices = co.lattice_vertices();
      const size_t lattice = cap * PermutohedralLattice::kBytesPerPoint +
                             static_cast<size_t>(vertices) * PermutohedralLattice::kBytesPerVertex +
                             PermutohedralLattice::kValues * sizeof(float);
      const size_t scratch = PermutohedralLattice::scratch_floats(vertices) * sizeof(float);
      const size_t per_surfel = PermutohedralLattice::kValues * sizeof(uint16_t) + sizeof(uint32_t);  // Q, order
      add("dense crf", 2 * lattice + 2 * scratch + cap * per_surfel,
          std::to_string(cap) + " surfels x " + std::to_string(semantic::DenseCrf::kBytesPerSurfel) + " + " +
              std::to_string(vertices) + " lattice vertices x about " +
              std::to_string(semantic::DenseCrf::kBytesPerVertex) + " (semantic/dense_crf.h)");
    }
  }

  {  // Prepared frames (pipeline/front_stage.h): per slot the working frame, its preprocessor
     // and, with labels, the CNN's probabilities and class ids. threads = 1 uses one slot.
    const size_t slots = config.threads == 1 ? 1 : static_cast<size_t>(config.prepared_slots);
    add("prepared frames", slots * (px(w, h) * kFrameBytesPerPixel + preprocessor_bytes + cnn_result),
        std::to_string(slots) + " slots x (working frame " + size_text(w, h) + " + pyramids" +
            (config.labels ? " + CNN result" : "") + ")");
  }

  for (const MemoryPart& p : plan.parts) plan.total_bytes += p.bytes;
  plan.budget_bytes = static_cast<size_t>(config.memory_budget_mb) * 1'000'000;
  return plan;
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
                   std::to_string(config.memory_budget_mb) + " MB (memory.budget_mb); largest parts: " + parts +
                   ". Lower mapping.surfel_capacity (or the resolution, or turn the CRF off) or raise "
                   "memory.budget_mb; `edgefusion plan` with the same options lists every part");
}

}  // namespace ef::pipeline
