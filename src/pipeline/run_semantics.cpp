#include "pipeline/run_semantics.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <thread>

#include "io/image_codec.h"
#include "io/label_image.h"
#include "pipeline/cnn_worker.h"
#include "pipeline/model_paths.h"
#include "semantic/label_render.h"
#include "semantic/label_store.h"

namespace ef::pipeline {

SemanticsOptions semantics_options(const RunConfig& config, int64_t crf_nodes) {
  SemanticsOptions o;
  o.labels = config.labels;
  o.fusion = config.label_fusion;
  o.crf = config.crf;
  o.dense_crf = crf_options_for_run(config, crf_nodes);
  o.pool_capacity = config.mapping.pool.capacity;
  o.prediction = config.mapping.prediction;
  o.source = config.run.source;
  return o;
}

std::string RunSemantics::model_path(const LabelOptions& labels, const std::string& source_uri) {
  return labels.model.empty() ? default_model_path(source_uri) : labels.model;
}

std::size_t RunSemantics::rendering_bytes_for(int working_width, int working_height) {
  // The class ids, and their palette colours for the images beside them.
  return std::size_t(working_width) * std::size_t(working_height) * (1 + sizeof(Rgb8));
}

std::string color_label_folder(const std::string& labels_out) {
  std::string dir = labels_out;
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  return dir + "_color";
}

semantic::LabelFusionOptions RunSemantics::fusion_options(const SemanticsOptions& options, int working_width,
                                                         int working_height, int cnn_width, int cnn_height) {
  semantic::LabelFusionOptions o = options.fusion;
  o.working_width = working_width;
  o.working_height = working_height;
  o.cnn_width = cnn_width;
  o.cnn_height = cnn_height;
  return o;
}

std::size_t RunSemantics::late_fusion_bytes_for(int working_width, int working_height,
                                                const slam::PredictionOptions& prediction) {
  return slam::ModelPredictor::bytes_for(working_width, working_height, 1, prediction) +
         std::size_t(kPoseHistory) * sizeof(PoseRecord);
}

std::size_t RunSemantics::class_column_bytes_for(int64_t pool_capacity) {
  return std::size_t(pool_capacity) * (sizeof(uint8_t) + sizeof(float));
}

std::string label_image_path(const std::string& dir, const Frame& frame) {
  char numbered[32];
  std::snprintf(numbered, sizeof numbered, "%06lld", static_cast<long long>(frame.index));
  const std::string name = frame.name.empty() ? std::string(numbered) : frame.name;
  return (std::filesystem::path(dir) / (name + ".png")).string();
}

Result<std::unique_ptr<RunSemantics>> RunSemantics::create(const SemanticsOptions& options, const Intrinsics& working,
                                                           StageStats& stats) {
  std::unique_ptr<RunSemantics> s(new RunSemantics());
  s->options_ = options;
  const bool default_model = options.labels.model.empty();
  s->model_path_ = model_path(options.labels, options.source);
  EF_RETURN_IF_ERROR(check_model_file(s->model_path_, default_model));
  semantic::SegmenterOptions seg_options;
  seg_options.frame_width = working.width;  // the CNN reads working frames: resampled without allocating
  seg_options.frame_height = working.height;
  auto seg = semantic::Segmenter::create(s->model_path_, seg_options);
  if (!seg.ok()) return seg.take_error();
  s->segmenter_ = std::move(*seg);
  if (s->segmenter_->num_classes() != semantic::kLabelClasses)
    return error(ErrorCode::kUnsupported, "model '" + s->model_path_ + "' has " +
                                              std::to_string(s->segmenter_->num_classes()) +
                                              " classes; label fusion needs " +
                                              std::to_string(semantic::kLabelClasses) +
                                              " (unknown + the 13 NYUv2 classes)");

  auto fusion = semantic::LabelFusion::create(fusion_options(options, working.width, working.height,
                                                             s->segmenter_->output_width(),
                                                             s->segmenter_->output_height()));
  if (!fusion.ok()) return fusion.take_error();
  s->fusion_ = std::make_unique<semantic::LabelFusion>(std::move(*fusion));

  if (options.crf.on()) {
    auto crf = semantic::DenseCrf::create(options.dense_crf);
    if (!crf.ok()) return crf.take_error();
    s->crf_ = std::make_unique<semantic::DenseCrf>(std::move(*crf));
  }

  auto view = slam::ModelPredictor::create(working, 1, options.prediction);
  if (!view.ok()) return view.take_error();
  s->label_view_.emplace(std::move(*view));
  s->poses_.assign(kPoseHistory, PoseRecord{});

  s->rendered_.allocate(working.width, working.height);
  s->rendered_color_.allocate(working.width, working.height);
  s->class_id_.assign(static_cast<std::size_t>(options.pool_capacity), 0);
  s->class_prob_.assign(static_cast<std::size_t>(options.pool_capacity), 0.0f);

  for (const std::string& dir : {options.labels.out, options.labels.out.empty() ? std::string() :
                                                     color_label_folder(options.labels.out),
                                 options.labels.final_out}) {
    if (dir.empty()) continue;
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) return error(ErrorCode::kIoError, "cannot create the label output folder '" + dir + "': " + ec.message());
  }

  s->stats_ = &stats;
  s->st_segment_ = stats.add_stage(kStageNames[0]);
  s->st_fuse_ = stats.add_stage(kStageNames[1]);
  s->st_render_ = stats.add_stage(kStageNames[2]);
  s->st_crf_ = stats.add_stage(kStageNames[3]);
  s->c_cnn_frames_ = stats.add_counter("cnn_frames");
  s->c_surfel_updates_ = stats.add_counter("surfel_label_updates");
  s->c_hidden_ = stats.add_counter("label_cells_hidden");
  s->c_no_depth_ = stats.add_counter("label_cells_without_depth");
  s->c_label_images_ = stats.add_counter("label_images_written");
  s->c_crf_runs_ = stats.add_counter("crf_runs");
  s->c_crf_left_out_ = stats.add_counter("crf_surfels_left_out");
  s->c_crf_unconfident_ = stats.add_counter("crf_surfels_unconfident");
  s->c_crf_beyond_ = stats.add_counter("crf_surfels_beyond_capacity");
  s->c_late_ = stats.add_counter("cnn_results_late");
  s->c_unfused_ = stats.add_counter("cnn_results_unfused");
  return s;
}

std::string RunSemantics::describe() const {
  std::ostringstream o;
  o << "model " << model_path_ << " (" << segmenter_->input_width() << "x" << segmenter_->input_height() << " -> "
    << segmenter_->num_classes() << " classes at " << segmenter_->output_width() << "x"
    << segmenter_->output_height() << "), labels every " << options_.fusion.update_every_n_frames << " frames, CRF ";
  if (crf_ == nullptr) o << "off";
  else {
    if (options_.crf.every > 0) o << "every " << options_.crf.every << " frames";
    if (options_.crf.final) o << (options_.crf.every > 0 ? " and " : "") << "at the end";
    o << " (" << options_.dense_crf.iterations << " iterations)";
  }
  if (!options_.labels.out.empty())
    o << ", label images every " << options_.labels.out_every << " frames into " << options_.labels.out;
  return o.str();
}

bool RunSemantics::fusion_due(int64_t frame_number) const { return fusion_->due(frame_number); }

bool RunSemantics::image_due(int64_t frame_number) const {
  return !options_.labels.out.empty() && frame_number % options_.labels.out_every == 0;
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

Status RunSemantics::fuse_job(const CnnJob& job, int64_t now, const Frame* working,
                              const slam::SlamFrameResult* result, slam::SurfelSlam& slam) {
  const slam::IndexMap* map = nullptr;
  ImageView<const float> depth;
  SE3 pose;
  if (job.number == now) {
    // This frame's own result: the index map SLAM has just rendered at its pose.
    if (result->lost) {
      stats_->increment(c_unfused_);
      return Status::success();
    }
    map = &slam.predictor_with_index_map().index_map();
    depth = working->depth.view();
    pose = result->T_world_cam;
  } else {
    // A result that came after its frame was mapped: the map as it is now, seen from that frame's pose.
    const PoseRecord& p = poses_[std::size_t(job.number % kPoseHistory)];
    if (p.frame != job.number || p.lost) {
      stats_->increment(c_unfused_);
      return Status::success();
    }
    label_view_->render_index_map(slam.pool(), p.T_world_cam);
    map = &label_view_->index_map();
    depth = job.frame.depth.view();
    pose = p.T_world_cam;
    stats_->increment(c_late_);
  }
  ScopedStageTimer t(*stats_, st_fuse_);
  auto counts = fusion_->fuse(*map, job.cnn.view(), slam.pool_for_labels(), visible_depth(depth));
  if (!counts.ok()) return counts.take_error();
  stats_->increment(c_surfel_updates_, static_cast<uint64_t>(counts->surfels_updated));
  stats_->increment(c_hidden_, static_cast<uint64_t>(counts->hidden_skipped));
  stats_->increment(c_no_depth_, static_cast<uint64_t>(counts->no_depth_skipped));
  last_fused_ = FusedResult{job.number, now, pose};
  return Status::success();
}

Status RunSemantics::on_frame(int64_t frame_number, const Frame& working, bool wait_for_this,
                              const slam::SlamFrameResult& result, slam::SurfelSlam& slam, CnnWorker& worker) {
  poses_[std::size_t(frame_number % kPoseHistory)] = PoseRecord{frame_number, result.T_world_cam, result.lost};
  if (result.loop_accepted) {
    // A loop closure moved the map: late results are fused at their frames' corrected poses (the
    // SLAM's pose history numbers frames as this stage does: one SLAM frame per frame delivered).
    for (PoseRecord& p : poses_)
      if (p.frame >= 0) (void)slam.pose_history().at_frame(p.frame, &p.T_world_cam);
  }
  CnnJob* own = nullptr;  // this frame's result, kept for its label image
  int64_t wait_for = wait_for_this ? frame_number : -1;
  Status status;
  while (CnnJob* job = worker.take(frame_number, wait_for)) {
    wait_for = -1;
    if (job->error) {
      status = *job->error;
      worker.release(job);
      break;
    }
    stats_->record_ms(st_segment_, job->cnn.segment_ms);  // measured on the CNN's thread
    stats_->increment(c_cnn_frames_);
    log_labels(*job);
    if (job->fuse) status = fuse_job(*job, frame_number, &working, &result, slam);
    if (job->number == frame_number && status.ok()) {
      own = job;
      continue;
    }
    worker.release(job);
    if (!status.ok()) break;
  }
  if (status.ok() && crf_ != nullptr && options_.crf.every > 0 && frame_number > 0 &&
      frame_number % options_.crf.every == 0)
    status = run_crf(slam);
  if (status.ok() && image_due(frame_number)) {
    if (own == nullptr)
      status = error(ErrorCode::kInvalidArgument,
                     "labels: frame " + std::to_string(frame_number) + " needs the CNN's result and has none");
    else
      status = write_rendering(working, own->cnn, result, slam);
  }
  if (own != nullptr) worker.release(own);
  return status;
}

Status RunSemantics::drain(int64_t last_frame, slam::SurfelSlam& slam, CnnWorker& worker) {
  while (true) {
    const bool more = worker.pending(last_frame);
    CnnJob* job = worker.take(last_frame, -1);
    if (job == nullptr) {
      if (!more) return Status::success();
      // Wait for the job still running: take() waits for a given frame, so ask for the oldest one.
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      continue;
    }
    Status status = job->error ? Status(*job->error) : Status::success();
    if (status.ok()) {
      stats_->record_ms(st_segment_, job->cnn.segment_ms);
      stats_->increment(c_cnn_frames_);
      log_labels(*job);
      if (job->fuse) status = fuse_job(*job, last_frame + 1, nullptr, nullptr, slam);
    }
    worker.release(job);
    if (!status.ok()) return status;
  }
}

void RunSemantics::log_labels(const CnnJob& job) {
  // A failed log keeps its first error (reported with the run's outputs); labelling goes on.
  if (log_ != nullptr && job.cnn.valid && !job.cnn.labels.empty())
    (void)log_->log_labels(job.frame.timestamp, job.cnn.labels.cview(), *log_encoder_);
}

Status RunSemantics::run_crf(slam::SurfelSlam& slam) {
  ScopedStageTimer t(*stats_, st_crf_);
  auto r = crf_->run(slam.pool_for_labels());
  if (!r.ok()) return r.take_error();
  stats_->increment(c_crf_runs_);
  stats_->increment(c_crf_left_out_, static_cast<uint64_t>(r->surfels_left_out));
  stats_->increment(c_crf_unconfident_, static_cast<uint64_t>(r->surfels_unconfident));
  stats_->increment(c_crf_beyond_, static_cast<uint64_t>(r->surfels_beyond_capacity));
  std::fprintf(stderr,
               "\ndense CRF at frame %lld: %lld surfels (%lld below crf.min_confidence and %lld seen longest ago "
               "beyond its capacity of %lld, left as fused), lattice vertices %lld bilateral / %lld spatial, %lld left "
               "out (lattice full), %d iterations, %.0f ms\n",
               static_cast<long long>(slam.frames()), static_cast<long long>(r->surfels),
               static_cast<long long>(r->surfels_unconfident), static_cast<long long>(r->surfels_beyond_capacity),
               static_cast<long long>(crf_->options().capacity), static_cast<long long>(r->bilateral_vertices),
               static_cast<long long>(r->spatial_vertices), static_cast<long long>(r->surfels_left_out), r->iterations,
               r->total_ms);
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
    auto r = semantic::render_labels(slam.predictor_with_index_map(), slam.pool(), cnn.labels.view(), rendered_.view(),
                                     visible_depth(working.depth.view()));
    if (!r.ok()) return r.take_error();
  }
  EF_RETURN_IF_ERROR(write_label_png_ids(label_image_path(options_.labels.out, working), rendered_.view()));
  // The same in the paper's palette, for eyes (the ids above are for `edgefusion eval labels`).
  colorize_labels(rendered_.cview(), rendered_color_.view());
  EF_RETURN_IF_ERROR(write_png(label_image_path(color_label_folder(options_.labels.out), working), rendered_color_.cview()));
  stats_->increment(c_label_images_);
  return Status::success();
}

Status RunSemantics::finish(slam::SurfelSlam& slam) {
  if (crf_ != nullptr && options_.crf.final && last_crf_frame_ != slam.frames()) return run_crf(slam);
  return Status::success();
}

void RunSemantics::add_label_columns(const slam::SurfelPool& pool, SurfelCloudView& view) {
  const std::size_t n = static_cast<std::size_t>(pool.size());
  semantic::label_summary(pool.labels(), n, class_id_.data(), class_prob_.data());
  view.class_id = Column<uint8_t>(class_id_.data());
  view.class_prob = Column<float>(class_prob_.data());
}

}  // namespace ef::pipeline
