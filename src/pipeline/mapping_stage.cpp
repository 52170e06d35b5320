#include "pipeline/mapping_stage.h"

#include <cstdio>
#include <iterator>

#include "core/stopwatch.h"

namespace ef::pipeline {

slam::SurfelSlamOptions MappingStage::slam_options(const slam::SurfelSlamOptions& options) {
  slam::SurfelSlamOptions o = options;
  o.own_preprocessor = false;  // the front step preprocesses, into each slot's own Preprocessor
  return o;
}

Result<std::unique_ptr<MappingStage>> MappingStage::create(const slam::SurfelSlamOptions& options,
                                                           const Intrinsics& working, StageStats& stats,
                                                           RunSemantics* semantics, const std::string& trajectory_path,
                                                           double sync_seconds, int64_t resume_trajectory_bytes) {
  auto slam = slam::SurfelSlam::create(working, slam_options(options));
  if (!slam.ok()) return slam.take_error();
  std::unique_ptr<MappingStage> m(new MappingStage(std::move(*slam), stats, semantics));
  if (resume_trajectory_bytes >= 0)
    EF_RETURN_IF_ERROR(m->trajectory_.open_append(trajectory_path, resume_trajectory_bytes, sync_seconds));
  else
    EF_RETURN_IF_ERROR(m->trajectory_.open(trajectory_path, sync_seconds));
  int ids[std::size(kStageNames)];
  for (std::size_t i = 0; i < std::size(kStageNames); ++i) ids[i] = stats.add_stage(kStageNames[i]);
  m->st_ = StageIds{ids[0], ids[1], ids[2], ids[3], ids[4],  ids[5],  ids[6],
                    ids[7], ids[8], ids[9], ids[10], ids[11], ids[12]};
  m->c_ = CounterIds{stats.add_counter("frames"),          stats.add_counter("frames_with_pose"),
                     stats.add_counter("frames_with_labels"), stats.add_counter("lost_frames"),
                     stats.add_counter("fused_frames"),    stats.add_counter("relocalisations"),
                     stats.add_counter("frames_lost_before_relocalisation"), stats.add_counter("keyframes"),
                     stats.add_counter("loop_closures_local"), stats.add_counter("loop_closures_local_rejected"),
                     stats.add_counter("loop_closures_global"), stats.add_counter("loop_closures_global_rejected")};
  return m;
}

Status MappingStage::step(const PreparedFrame& slot) {
  const SteadyClock::time_point t_start = SteadyClock::now();
  stats_.record_ms(st_.source, slot.source_ms);
  stats_.record_ms(st_.resample, slot.resample_ms);
  stats_.record_ms(st_.preprocess, slot.preprocess_ms);
  stats_.record_ms(st_.front, slot.source_ms + slot.resample_ms + slot.preprocess_ms + slot.log_ms);
  if (slot.logged) stats_.record_ms(st_.log, slot.log_ms);

  const Frame& frame = slot.working;
  EF_RETURN_IF_ERROR(slam_.process(frame, *slot.pre, &result_));
  if (frames_ > 0) stats_.record_ms(st_.track, result_.timings.track_ms);  // frame 0 has nothing to track
  if (result_.fused) stats_.record_ms(st_.fuse, result_.timings.fuse_ms);
  if (result_.fused) stats_.record_ms(st_.predict, result_.timings.predict_ms);
  stats_.record_ms(st_.slam, result_.timings.total_ms);
  // Only on the frames that do it: lost ones (and the one that resumes), tracked ones.
  if (result_.lost || result_.relocalised) stats_.record_ms(st_.relocalise, result_.timings.relocalise_ms);
  if (result_.fused && frames_ > 0) stats_.record_ms(st_.keyframe, result_.timings.keyframe_ms);
  if (result_.timings.loop_ms > 0) stats_.record_ms(st_.loop, result_.timings.loop_ms);
  if (semantics_ != nullptr && cnn_ != nullptr)
    EF_RETURN_IF_ERROR(semantics_->on_frame(slot.number, frame, slot.cnn_wait, result_, slam_, *cnn_));

  if (result_.lost) {
    std::snprintf(line_, sizeof line_, "lost %.6f %s", frame.timestamp,
                  slam::track_lost_reason_name(result_.track.reason));
    EF_RETURN_IF_ERROR(trajectory_.write_comment(line_));
  } else if (result_.relocalised) {
    if (result_.keyframe >= 0)
      std::snprintf(line_, sizeof line_, "relocalised %.6f after %lld lost frames (this one: %s), at keyframe %d (frame %d)",
                    frame.timestamp, static_cast<long long>(result_.lost_before),
                    slam::track_lost_reason_name(result_.tracking_lost), static_cast<int>(result_.keyframe),
                    static_cast<int>(slam_.keyframes().frame(result_.keyframe)));
    else
      std::snprintf(line_, sizeof line_, "relocalised %.6f after %lld lost frames, from the last good pose",
                    frame.timestamp, static_cast<long long>(result_.lost_before));
    EF_RETURN_IF_ERROR(trajectory_.write_comment(line_));
  }
  if (result_.loop_kind != slam::LoopKind::kNone) {
    std::snprintf(line_, sizeof line_, "loop closure %.6f %s %s: camera moved %.4f m, constraints %.4f -> %.4f m RMS",
                  frame.timestamp, slam::loop_kind_name(result_.loop_kind),
                  result_.loop_accepted ? "accepted" : "rejected", result_.loop_correction_m,
                  result_.deformation.rms_before_m, result_.deformation.rms_after_m);
    EF_RETURN_IF_ERROR(trajectory_.write_comment(line_));
    if (log_ != nullptr)
      (void)log_->log_text(frame.timestamp, foxglove::LogLevel::kInfo, line_, *log_encoder_);
  }
  EF_RETURN_IF_ERROR(trajectory_.write(frame.timestamp, result_.T_world_cam));
  if (log_ != nullptr) {
    // A failed log keeps its first error, reported with the outputs; the mapping goes on.
    (void)log_->log_pose(frame.timestamp, result_.T_world_cam, *log_encoder_);
    // The loss, and the relocalisation that ends it (line_ says which of the two).
    if (result_.lost != was_lost_ || result_.relocalised)
      (void)log_->log_text(frame.timestamp, result_.lost ? foxglove::LogLevel::kWarning : foxglove::LogLevel::kInfo,
                           line_, *log_encoder_);
    was_lost_ = result_.lost;
    if (!pool_full_logged_ && slam_.pool().full()) {
      pool_full_logged_ = true;
      (void)log_->log_text(frame.timestamp, foxglove::LogLevel::kWarning,
                           "surfel pool full: evicting the surfels unseen longest from now on", *log_encoder_);
    }
  }
  stats_.increment(c_.frames);
  stats_.increment(c_.with_pose, frame.has_pose ? 1 : 0);
  stats_.increment(c_.with_labels, frame.has_labels ? 1 : 0);
  stats_.increment(c_.lost, result_.lost ? 1 : 0);
  stats_.increment(c_.fused, result_.fused ? 1 : 0);
  stats_.increment(c_.relocalisations, result_.relocalised ? 1 : 0);
  stats_.increment(c_.lost_before_relocalisation, result_.relocalised ? static_cast<uint64_t>(result_.lost_before) : 0);
  stats_.increment(c_.keyframes, result_.new_keyframe ? 1 : 0);
  if (result_.loop_kind != slam::LoopKind::kNone) {
    const bool local = result_.loop_kind == slam::LoopKind::kLocal;
    stats_.increment(result_.loop_accepted ? (local ? c_.loop_local_accepted : c_.loop_global_accepted)
                                           : (local ? c_.loop_local_rejected : c_.loop_global_rejected));
  }
  ++frames_;
  last_timestamp_ = frame.timestamp;
  stats_.record_ms(st_.mapping, ms_since(t_start));
  return Status::success();
}

Result<TumRewrite> MappingStage::close_trajectory() {
  EF_RETURN_IF_ERROR(trajectory_.close());
  const slam::PoseHistory& history = slam_.pose_history();
  if (history.deformations() == 0 || final_bytes_ >= 0) return TumRewrite{};
  // Lines of frames older than the history stay as tracked; the comment says how many.
  const std::string key = "poses corrected by loop closure";
  const std::string comment = key + " (" + std::to_string(history.deformations()) + " closures): every frame's from " +
                              std::to_string(history.first_frame()) + " on; " + std::to_string(history.overwritten()) +
                              " earlier ones as tracked (mapping.pose_history " + std::to_string(history.capacity()) + ")";
  auto rewritten = rewrite_tum_poses(
      trajectory_.path(), [&history](double t, SE3* T) { return history.at_time(t, T); }, comment, key.size());
  if (!rewritten.ok()) return rewritten.take_error();
  final_bytes_ = rewritten->bytes;
  return rewritten;
}

Status MappingStage::drain_cnn() {
  if (semantics_ == nullptr || cnn_ == nullptr) return Status::success();
  return semantics_->drain(frames_ - 1, slam_, *cnn_);
}

}  // namespace ef::pipeline
