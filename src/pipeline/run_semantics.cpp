#include "pipeline/run_semantics.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "io/label_image.h"
#include "pipeline/model_paths.h"
#include "semantic/label_render.h"
#include "semantic/label_store.h"

namespace ef::pipeline {

semantic::DenseCrfOptions run_crf_options(const RunConfig& config) {
  semantic::DenseCrfOptions co;
  co.capacity = config.surfel_capacity;
  co.iterations = config.crf_iterations;
  // Lattice vertices per surfel of capacity. A SurfelSlam map needs more than the CRF's default
  // (0.3, measured on noise-free sampled surfaces): on the synthetic seed-5001 loop (370k surfels
  // after 300 frames) the spatial kernel's lattice had 1.13 vertices per surfel (noisy normals
  // spread it) and the bilateral one 0.80. 1.25 leaves none out there; the cost is
  // DenseCrf::kBytesPerVertex per vertex (docs/architecture.md, memory budget).
  co.max_lattice_vertices = config.surfel_capacity * 5 / 4;
  return co;
}

std::string label_image_path(const std::string& dir, const Frame& frame) {
  char numbered[32];
  std::snprintf(numbered, sizeof numbered, "%06lld", static_cast<long long>(frame.index));
  const std::string name = frame.name.empty() ? std::string(numbered) : frame.name;
  return (std::filesystem::path(dir) / (name + ".png")).string();
}

Result<std::unique_ptr<RunSemantics>> RunSemantics::create(const RunConfig& config, const Intrinsics& working,
                                                           StageStats& stats) {
  std::unique_ptr<RunSemantics> s(new RunSemantics());
  s->config_ = config;
  const bool default_model = config.model.empty();
  s->model_path_ = default_model ? default_model_path() : config.model;
  EF_RETURN_IF_ERROR(check_model_file(s->model_path_, default_model));
  auto seg = semantic::Segmenter::create(s->model_path_);
  if (!seg.ok()) return seg.take_error();
  s->segmenter_ = std::move(*seg);
  if (s->segmenter_->num_classes() != semantic::kLabelClasses)
    return error(ErrorCode::kUnsupported, "model '" + s->model_path_ + "' has " +
                                              std::to_string(s->segmenter_->num_classes()) +
                                              " classes; label fusion needs " +
                                              std::to_string(semantic::kLabelClasses) +
                                              " (unknown + the 13 NYUv2 classes)");

  semantic::LabelFusionOptions fo;
  fo.update_every_n_frames = config.label_every;
  fo.working_width = working.width;
  fo.working_height = working.height;
  fo.cnn_width = s->segmenter_->output_width();
  fo.cnn_height = s->segmenter_->output_height();
  auto fusion = semantic::LabelFusion::create(fo);
  if (!fusion.ok()) return fusion.take_error();
  s->fusion_ = std::make_unique<semantic::LabelFusion>(std::move(*fusion));

  if (config.crf_every > 0 || config.crf_final) {
    const semantic::DenseCrfOptions co = run_crf_options(config);
    auto crf = semantic::DenseCrf::create(co);
    if (!crf.ok()) return crf.take_error();
    s->crf_ = std::make_unique<semantic::DenseCrf>(std::move(*crf));
  }

  s->rendered_.allocate(working.width, working.height);
  s->class_id_.assign(static_cast<std::size_t>(config.surfel_capacity), 0);
  s->class_prob_.assign(static_cast<std::size_t>(config.surfel_capacity), 0.0f);

  for (const std::string& dir : {config.labels_out, config.labels_final_out}) {
    if (dir.empty()) continue;
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) return error(ErrorCode::kIoError, "cannot create the label output folder '" + dir + "': " + ec.message());
  }

  s->stats_ = &stats;
  s->st_segment_ = stats.add_stage("segment");
  s->st_fuse_ = stats.add_stage("label_fuse");
  s->st_render_ = stats.add_stage("label_render");
  s->st_crf_ = stats.add_stage("crf");
  s->c_cnn_frames_ = stats.add_counter("cnn_frames");
  s->c_surfel_updates_ = stats.add_counter("surfel_label_updates");
  s->c_hidden_ = stats.add_counter("label_cells_hidden");
  s->c_no_depth_ = stats.add_counter("label_cells_without_depth");
  s->c_label_images_ = stats.add_counter("label_images_written");
  s->c_crf_runs_ = stats.add_counter("crf_runs");
  s->c_crf_left_out_ = stats.add_counter("crf_surfels_left_out");
  return s;
}

std::string RunSemantics::describe() const {
  std::ostringstream o;
  o << "model " << model_path_ << " (" << segmenter_->input_width() << "x" << segmenter_->input_height() << " -> "
    << segmenter_->num_classes() << " classes at " << segmenter_->output_width() << "x"
    << segmenter_->output_height() << "), labels every " << config_.label_every << " frames, CRF ";
  if (crf_ == nullptr) o << "off";
  else {
    if (config_.crf_every > 0) o << "every " << config_.crf_every << " frames";
    if (config_.crf_final) o << (config_.crf_every > 0 ? " and " : "") << "at the end";
    o << " (" << config_.crf_iterations << " iterations)";
  }
  if (!config_.labels_out.empty())
    o << ", label images every " << config_.labels_out_every << " frames into " << config_.labels_out;
  return o.str();
}

bool RunSemantics::cnn_due(int64_t frame_number) const {
  return fusion_->due(frame_number) || (!config_.labels_out.empty() && frame_number % config_.labels_out_every == 0);
}

void RunSemantics::allocate(CnnResult& out) const {
  const semantic::ProbabilityView p = segmenter_->probabilities();
  out.probabilities.assign(p.floats(), 0.0f);
  out.width = p.width;
  out.height = p.height;
  out.classes = p.classes;
  out.labels.allocate(rendered_.width(), rendered_.height());
  out.valid = false;
}

Status RunSemantics::segment(const Frame& working, CnnResult& out) {
  const auto t0 = std::chrono::steady_clock::now();
  out.valid = false;
  EF_RETURN_IF_ERROR(segmenter_->segment(working, out.labels.view()));
  const semantic::ProbabilityView p = segmenter_->probabilities();
  if (p.floats() != out.probabilities.size())
    return error(ErrorCode::kInvalidArgument, "segment: the CNN result slot was not sized by RunSemantics::allocate");
  std::copy(p.data, p.data + p.floats(), out.probabilities.begin());
  out.segment_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  out.valid = true;
  return Status::success();
}

Status RunSemantics::on_frame(int64_t frame_number, const Frame& working, const CnnResult& cnn,
                              const slam::SlamFrameResult& result, slam::SurfelSlam& slam) {
  const bool fuse_now = !result.lost && fusion_->due(frame_number);
  const bool write_now = !config_.labels_out.empty() && frame_number % config_.labels_out_every == 0;
  if ((fuse_now || write_now) && !cnn.valid)
    return error(ErrorCode::kInvalidArgument,
                 "labels: frame " + std::to_string(frame_number) + " needs the CNN's result and has none");
  if (cnn.valid) {
    stats_->record_ms(st_segment_, cnn.segment_ms);  // measured on the front stage
    stats_->increment(c_cnn_frames_);
  }
  if (fuse_now) {
    ScopedStageTimer t(*stats_, st_fuse_);
    auto counts = fusion_->fuse(slam.predictor().index_map(), cnn.view(), slam.pool_for_labels(),
                                config_.label_visibility ? working.depth.view() : ImageView<const float>());
    if (!counts.ok()) return counts.take_error();
    stats_->increment(c_surfel_updates_, static_cast<uint64_t>(counts->surfels_updated));
    stats_->increment(c_hidden_, static_cast<uint64_t>(counts->hidden_skipped));
    stats_->increment(c_no_depth_, static_cast<uint64_t>(counts->no_depth_skipped));
  }
  if (crf_ != nullptr && config_.crf_every > 0 && frame_number > 0 && frame_number % config_.crf_every == 0) {
    EF_RETURN_IF_ERROR(run_crf(slam));
  }
  if (write_now) EF_RETURN_IF_ERROR(write_rendering(working, cnn, result, slam));
  return Status::success();
}

Status RunSemantics::run_crf(slam::SurfelSlam& slam) {
  ScopedStageTimer t(*stats_, st_crf_);
  auto r = crf_->run(slam.pool_for_labels());
  if (!r.ok()) return r.take_error();
  stats_->increment(c_crf_runs_);
  stats_->increment(c_crf_left_out_, static_cast<uint64_t>(r->surfels_left_out));
  std::fprintf(stderr,
               "\ndense CRF at frame %lld: %lld surfels, lattice vertices %lld bilateral / %lld spatial, %lld left out "
               "(lattice full), %d iterations, %.0f ms\n",
               static_cast<long long>(slam.frames()), static_cast<long long>(r->surfels),
               static_cast<long long>(r->bilateral_vertices), static_cast<long long>(r->spatial_vertices),
               static_cast<long long>(r->surfels_left_out), r->iterations, r->total_ms);
  last_crf_frame_ = slam.frames();
  return Status::success();
}

Status RunSemantics::write_rendering(const Frame& working, const CnnResult& cnn, const slam::SlamFrameResult& result,
                                     slam::SurfelSlam& slam) {
  ScopedStageTimer t(*stats_, st_render_);
  if (result.lost) {
    // The prediction still shows the last good pose: the CNN's own prediction is all we have.
    rendered_.copy_from(cnn.labels.view());
  } else {
    auto r = semantic::render_labels(slam.predictor(), slam.pool(), cnn.labels.view(), rendered_.view(),
                                     config_.label_visibility ? working.depth.view() : ImageView<const float>());
    if (!r.ok()) return r.take_error();
  }
  EF_RETURN_IF_ERROR(write_label_png_ids(label_image_path(config_.labels_out, working), rendered_.view()));
  stats_->increment(c_label_images_);
  return Status::success();
}

Status RunSemantics::finish(slam::SurfelSlam& slam) {
  if (crf_ != nullptr && config_.crf_final && last_crf_frame_ != slam.frames()) return run_crf(slam);
  return Status::success();
}

void RunSemantics::add_label_columns(const slam::SurfelPool& pool, SurfelCloudView& view) {
  const std::size_t n = static_cast<std::size_t>(pool.size());
  semantic::label_summary(pool.labels(), n, class_id_.data(), class_prob_.data());
  view.class_id = Column<uint8_t>(class_id_.data());
  view.class_prob = Column<float>(class_prob_.data());
}

}  // namespace ef::pipeline
