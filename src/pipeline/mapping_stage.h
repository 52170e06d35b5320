// The mapping stage of `edgefusion run` (pipeline/run_pipeline.h): everything that reads or
// writes the map, in frame order, on one thread:
//
//   track + fuse + predict   SurfelSlam::process with the pyramids the front stage made
//   labels                   the CNN results that are done fused, each at its own frame's pose, the
//                            CRF when due, the label image when due (RunSemantics::on_frame)
//   trajectory               the frame's pose line (and '# lost ...' before it when lost)
//
// and it records the times of the front step and the CNN too into StageStats (they travel in the
// slot and the CNN's job, so StageStats is only ever written by this thread).
//
// Memory: create() allocates the SLAM (pool, pyramids, index map) and registers the stages;
// step() allocates nothing. Threads: one thread at a time.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "core/intrinsics.h"
#include "core/result.h"
#include "core/stage_stats.h"
#include "pipeline/front_stage.h"
#include "io/trajectory_io.h"
#include "pipeline/run_config.h"
#include "pipeline/run_semantics.h"
#include "slam/surfel_slam.h"

namespace ef::pipeline {

class MappingStage {
 public:
  // The stages it records into StageStats: the front step's (measured on its thread, carried in
  // the slot), the SLAM's steps and their sum, and the whole mapping step.
  static constexpr const char* kStageNames[] = {"source",        "resample", "preprocess", "front_total",
                                                "track",         "fuse",     "predict",    "slam_total",
                                                "mapping_total", "log",      "relocalise", "keyframe",
                                                "loop_check"};

  // options: the run's SLAM (the front step preprocesses, so the SLAM gets no preprocessor of its
  // own: options.own_preprocessor is set false here). working: intrinsics at the working
  // resolution. semantics: borrowed, may be null. The trajectory is written to `trajectory_path`
  // (created now), a whole line per frame, synced at most `sync_seconds` after a line
  // (io/trajectory_io.h); with resume_trajectory_bytes >= 0 (a resumed run) the existing file is
  // cut back to that length and continued. Errors: the SLAM's options, the file's.
  static Result<std::unique_ptr<MappingStage>> create(const slam::SurfelSlamOptions& options,
                                                      const Intrinsics& working, StageStats& stats,
                                                      RunSemantics* semantics, const std::string& trajectory_path,
                                                      double sync_seconds, int64_t resume_trajectory_bytes = -1);
  // A resumed run: `frames` were mapped before (the SLAM was restored from the checkpoint).
  void resume_at(int64_t frames) { frames_ = frames; }
  // The options create() gives the SLAM.
  static slam::SurfelSlamOptions slam_options(const slam::SurfelSlamOptions& options);

  // The CNN whose results on_frame() fuses (null without labels). Set once before the first step().
  void set_cnn(CnnWorker* cnn) { cnn_ = cnn; }
  // The field log (null: none) and the mapping thread's encoder, both borrowed: each mapped frame's
  // pose goes to it, and a line when tracking is lost or regained.
  void set_log(McapFrameLog* log, McapFrameLog::Encoder* encoder) {
    log_ = log;
    log_encoder_ = encoder;
  }
  // Maps one prepared frame (not an end marker). Errors: the SLAM's, the labels', a failed write of
  // the trajectory; the map keeps every frame mapped before.
  Status step(const PreparedFrame& slot);
  // After the last frame: the CNN's results still in flight fused (RunSemantics::drain).
  Status drain_cnn();

  slam::SurfelSlam& slam() { return slam_; }
  const slam::SurfelSlam& slam() const { return slam_; }
  const slam::SlamFrameResult& last_result() const { return result_; }
  int64_t frames() const { return frames_; }  // frames mapped (tracked or lost)
  // Closes the trajectory file (reports a failed final write). After loop closures, the file is then
  // rewritten whole with the corrected poses of the frames the SLAM's pose history holds
  // (slam/pose_history.h; io/trajectory_io.h rewrite_tum_poses): the lines written while mapping are
  // the poses as tracked, the final file has the poses in the deformed map's frame, and a comment
  // after the header says so. Returns what the rewrite did (all zeros without one). Allocates (the
  // file is read whole): not on the per-frame path.
  Result<TumRewrite> close_trajectory();
  // Syncs the trajectory and returns its length (for a checkpoint; after close_trajectory(), the
  // rewritten file's).
  Result<int64_t> sync_trajectory() {
    if (!trajectory_.is_open() && final_bytes_ >= 0) return final_bytes_;
    EF_RETURN_IF_ERROR(trajectory_.flush());
    return trajectory_.bytes();
  }
  double last_timestamp() const { return last_timestamp_; }

 private:
  MappingStage(slam::SurfelSlam slam, StageStats& stats, RunSemantics* semantics)
      : slam_(std::move(slam)), stats_(stats), semantics_(semantics) {}

  slam::SurfelSlam slam_;
  StageStats& stats_;
  RunSemantics* semantics_;
  CnnWorker* cnn_ = nullptr;
  McapFrameLog* log_ = nullptr;
  McapFrameLog::Encoder* log_encoder_ = nullptr;
  bool was_lost_ = false;
  bool pool_full_logged_ = false;  // the field log's one line when the pool first fills
  TumTrajectoryWriter trajectory_;
  slam::SlamFrameResult result_;
  int64_t frames_ = 0;
  int64_t final_bytes_ = -1;   // the rewritten trajectory's length (-1: not rewritten)
  double last_timestamp_ = 0;  // of the last mapped frame
  char line_[160] = {};  // the '# lost' comment, formatted without the heap
  struct StageIds {
    int source, resample, preprocess, front, track, fuse, predict, slam, mapping, log, relocalise, keyframe, loop;
  } st_{};
  struct CounterIds {
    int frames, with_pose, with_labels, lost, fused, relocalisations, lost_before_relocalisation, keyframes;
    int loop_local_accepted, loop_local_rejected, loop_global_accepted, loop_global_rejected;
  } c_{};
};

}  // namespace ef::pipeline
