// The pipeline of `edgefusion run`: from a frame source to trajectory.txt, map.ply and stats.json.
//
//   capture thread   live cameras only: source -> capture ring (pipeline.capture_slots, drop-oldest,
//                    counted as frames_dropped_overload); a camera is never held up by mapping
//   front            next frame -> resample -> preprocess (pipeline/front_stage.h); hands the
//                    frames a label update or a label image is due on to the CNN
//   CNN              the network beside the pipeline on a thread of its own (pipeline/cnn_worker.h):
//                    it takes a frame when it is free, and the mapping never waits for it
//                    (except for a label image's frame, and in a deterministic run)
//   mapping          track + fuse + predict, the CNN results that are done fused each at its own
//                    frame's pose, CRF, label images, trajectory line (pipeline/mapping_stage.h);
//                    then the observer (LED, progress line) and its stop requests (signals, the button)
//   outputs          write_outputs(): trajectory closed, final CRF, map.ply, stats.json
//
// Nothing accepted is lost (issue 29): the folder is a new run's (pipeline/run_folder.h); the
// trajectory gets a whole line per frame, synced every output.sync_seconds; stats.json is written
// at the start and rewritten every output.stats_seconds with "state": "running", and at the end with
// "finished" (the source ended or max_frames), "stopped" (a stop request), "camera lost" (a live
// camera that vanished: output.resume_interrupted continues such a run) or
// "failed: <reason>" (the run's error or an output's); map.ply and stats.json are whole or absent
// (io/durable_file.h). A killed run leaves its trajectory up to the last line, and a stats.json
// that parses and says "running".
//
// With log.file, a field log (io/mcap_log.h) is written beside: the front stage writes each source
// frame, the mapping thread each pose, the CNN's class ids and status lines, and each checkpoint the
// map and the open chunk; it is closed with the outputs (a log that failed is reported there).
//
// preview.png (pipeline/map_preview.h) is rewritten with each checkpoint (stage
// "checkpoint_preview") and at the end, drawn by one MapPreviewer made in create(): a killed run's
// folder has the picture of its last checkpoint's map.
//
// Front and mapping share a StageRing (core/stage_ring.h) of pipeline.prepared_slots PreparedFrame
// slots, which every frame passes through in order; a step waits for its predecessor, nothing is
// dropped after capture. pipeline.threads says how the steps map onto threads:
//   1  front, CNN and mapping take turns on the calling thread (one slot; the CNN runs on every
//      due frame and its result is fused at once: deterministic)
//   2  front on one thread with the CNN's thread on the same core, mapping on the calling thread
//      (the default)
//   3  front, CNN and mapping each on their own core
// With 2 or 3 threads the labels depend on when the CNN finishes, unless pipeline.deterministic:
// then the CNN takes exactly the due frames and the mapping waits for each result at its frame,
// and the outputs are those of one thread. The geometry never depends on the CNN. Each thread is
// pinned to its configured core.
//
// Ending: the source's end, max_frames, a source or CNN error, a mapping error, or the observer's
// stop request. A stop request drains the pipeline: the capture thread stops taking frames and every
// frame already captured or prepared is still mapped; then the outputs are written. A camera that
// disappears (is_camera_lost) ends the run like a stop, not as an error.
//
// Memory: create() allocates everything (SLAM, semantics, slots, rings); run() allocates nothing per
// frame (tests/pipeline/test_pipeline.cpp counts it over 3000 frames).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/stage_ring.h"
#include "core/result.h"
#include "core/stage_stats.h"
#include "pipeline/checkpoint.h"
#include "pipeline/map_preview.h"
#include "pipeline/cnn_worker.h"
#include "pipeline/final_labels.h"
#include "pipeline/front_stage.h"
#include "io/durable_file.h"
#include "io/frame_source.h"
#include "io/stats_json.h"
#include "pipeline/mapping_stage.h"
#include "pipeline/run_config.h"
#include "pipeline/run_report.h"
#include "io/trajectory_io.h"
#include "pipeline/run_semantics.h"

namespace ef::pipeline {

class RunPipeline;

// What the run asks and tells its owner between frames, on the mapping thread.
class RunObserver {
 public:
  virtual ~RunObserver() = default;
  // Checked before each frame: true ends the run (once true, the pipeline drains and ends).
  virtual bool stop_requested(const RunPipeline& /*pipeline*/) { return false; }
  // After each mapped frame.
  virtual void frame_mapped(const RunPipeline& /*pipeline*/) {}
};

struct RunOutcome {
  int64_t frames = 0;          // frames mapped
  double seconds = 0;          // wall time of run()
  bool stopped = false;        // the observer asked to stop
  bool camera_lost = false;    // the live camera disappeared (not an error: the outputs are complete)
  std::optional<Error> error;  // what ended the run early (the source's or mapping's error)
};

struct OutputFiles {
  std::string trajectory, map, stats;  // paths in the output folder
  std::string preview;                 // preview.png (pipeline/map_preview.h), when written
  bool wrote_preview = false;
  std::string report;                  // report.html (pipeline/run_report.h), when written
  bool wrote_report = false;
  std::string log;                     // the field log, when the run has one
  bool wrote_trajectory = false, wrote_map = false, wrote_stats = false, wrote_log = false;
  uint64_t log_frames = 0;
  // Pose lines of trajectory.txt that loop closures corrected, and those older than the pose
  // history left as tracked (both 0 without closures).
  int64_t trajectory_corrected = 0, trajectory_kept = 0;
  std::vector<Error> errors;  // each output that failed, in order
};

class RunPipeline {
 public:
  // The stage it records itself (the others: MappingStage's and RunSemantics').
  static constexpr const char* kStageNames[] = {"checkpoint", "log_map", "checkpoint_preview"};

  // source: borrowed, must outlive the pipeline. Checks the configuration (RunConfig::validate,
  // check_run), then creates the output folder and the trajectory file, the SLAM, the semantics
  // (labels.enabled), the slots and the rings; registers every stage and counter in `stats`
  // (borrowed). Errors: the configuration's, the folder's, the model's.
  static Result<std::unique_ptr<RunPipeline>> create(const RunConfig& config, FrameSource& source, StageStats& stats);
  ~RunPipeline();
  RunPipeline(const RunPipeline&) = delete;
  RunPipeline& operator=(const RunPipeline&) = delete;

  // The configuration it runs with: the one given, with pipeline.pinning "auto" resolved into the
  // *_cpu cores of this machine.
  const RunConfig& config() const { return config_; }

  // Runs until the source ends, max_frames, an error or a stop request (see the header).
  RunOutcome run(RunObserver& observer);

  // After run(): the final CRF (if asked for), then trajectory.txt closed, map.ply and stats.json.
  // Every output is attempted even when another failed.
  OutputFiles write_outputs(const RunOutcome& outcome);
  // After write_outputs(): the final map's labels in every labels_out_every-th frame of `replay`, the
  // same recording opened again, into labels.final_out (pipeline/final_labels.h).
  // Errors: a run without labels, and the pass's (they name the file or the frame).
  Result<FinalLabelCounts> render_final_labels(FrameSource& replay, const std::function<bool()>& stop = {});

  const slam::SurfelSlam& slam() const { return mapping_->slam(); }
  const MappingStage& mapping() const { return *mapping_; }
  const RunSemantics* semantics() const { return semantics_.get(); }
  // Frames dropped so far: a live camera's overload (ring full) plus the frames it reported corrupt.
  uint64_t frames_dropped() const { return front_->dropped_overload() + front_->corrupt_dropped(); }
  // --realtime: frames the machine released late (FrontStage::kRealtimeLateSeconds) and the most, ms.
  uint64_t realtime_late_frames() const { return front_->realtime_late_frames(); }
  int64_t realtime_max_late_ms() const { return front_->realtime_max_late_ms(); }
  // Bytes of one prepared slot (working frame, pyramids), for the memory line.
  std::size_t slot_bytes() const { return slot_bytes_; }
  // Bytes of the CNN's jobs (0 without labels).
  std::size_t cnn_job_bytes() const { return cnn_ != nullptr ? cnn_->bytes() : 0; }
  // The run's folder: run.out with "{time}" replaced (pipeline/run_folder.h).
  const std::string& out_folder() const { return out_folder_; }
  // A resumed run: the checkpoint it continues (frames mapped before), and a warning when the
  // newest checkpoint was corrupt and the one before it was used.
  const std::optional<CheckpointMeta>& resumed() const { return resumed_; }
  const std::string& resume_warning() const { return resume_warning_; }
  // The first preview.png a checkpoint could not write (mapping goes on; stats.json counts
  // checkpoint_previews_failed). Changes on the mapping thread: read it from the observer's calls.
  const std::optional<Error>& checkpoint_preview_error() const { return checkpoint_preview_error_; }
  // The field log's path ("" when the run has none): log.file in the run folder, or where it
  // points; a resumed run writes a log of its own beside the first, named <stem>.resume-<frame>.mcap
  // (an MCAP file is not continued after a cut: each session's log is whole on its own).
  const std::string& log_path() const { return log_path_; }
  // The field log's file for `file` (log.file), in `folder`, for a run resumed at `resumed_at`
  // frames (-1: not resumed).
  static std::string log_path_for(const std::string& file, const std::string& folder, int64_t resumed_at);

 private:
  RunPipeline(const RunConfig& config, FrameSource& source, StageStats& stats)
      : config_(resolved(config)), source_(source), stats_(stats) {}
  // The configuration with pipeline.pinning "auto" turned into cores of this machine.
  static RunConfig resolved(const RunConfig& config);
  // Maps one slot; an end slot sets the outcome instead. Returns false when the run is over.
  bool consume(PreparedFrame& slot, RunObserver& observer, RunOutcome& outcome);
  // The observer's stop request, passed on to the front stage once.
  void check_stop(RunObserver& observer, RunOutcome& outcome);
  // The loop of a thread that runs the front step (and the segment step when `with_segment`).
  void front_loop();
  // The counters kept by the parts (pool, front stage, CNN) copied into StageStats.
  void update_counters();
  // stats.json rewritten whole with `state`; allocates nothing once created (the JSON text's
  // capacity is reserved). On the mapping thread, between frames (StageStats' summaries).
  Status write_stats(const char* state, int64_t frames, double seconds);
  // A periodic rewrite when output.stats_seconds have passed.
  Status maybe_write_stats();
  // A checkpoint of the map now (pipeline/checkpoint.h); `seconds`: of this session so far. On the
  // mapping thread, between frames: the mapper pauses for it (stage "checkpoint" in stats.json),
  // and for preview.png drawn again with it (`with_preview`, stage "checkpoint_preview").
  Status checkpoint(double seconds, bool with_preview = true);
  Status maybe_checkpoint();

  const RunConfig config_;
  FrameSource& source_;
  StageStats& stats_;
  std::unique_ptr<RunSemantics> semantics_;
  std::unique_ptr<CnnWorker> cnn_;  // with labels
  std::unique_ptr<MappingStage> mapping_;
  std::unique_ptr<FrontStage> front_;
  std::unique_ptr<StageRing<PreparedFrame>> ring_;  // front -> mapping
  std::unique_ptr<McapFrameLog> log_;              // the field log, when log.file is set
  std::unique_ptr<McapFrameLog::Encoder> log_encoder_;  // the mapping thread's (poses, lines)
  std::string log_path_;
  std::size_t slot_bytes_ = 0;
  bool stop_sent_ = false;
  std::string out_folder_;
  RewrittenFile stats_file_;
  JsonWriter stats_json_;
  std::vector<StatsExtraField> stats_extra_;
  // Something done every `seconds` of wall time (0: never), checked between frames.
  struct Every {
    double seconds = 0;
    std::chrono::steady_clock::time_point next;
    void start(double interval_s, std::chrono::steady_clock::time_point now);
    bool due(std::chrono::steady_clock::time_point now);  // true at most once an interval
  };
  // stats_extra_'s fields that change during the run (the others are set once in create()).
  enum StatsExtra { kExtraSurfels = 3, kExtraPeakRss = 7, kExtraCheckpoints = 9 };
  std::chrono::steady_clock::time_point start_;
  Every stats_every_, checkpoint_every_;
  // The mapping rate over the run for report.html: (seconds, frames) every rate_interval_ seconds;
  // when full, every other sample goes and the interval doubles (fixed memory, any run length).
  static constexpr std::size_t kRateSamples = kReportRateSamples;
  // The source's reference poses (recordings that have them), every reference_stride_-th, at most
  // kReferencePoses (decimated like the rate): the report's ATE and reference path.
  static constexpr std::size_t kReferencePoses = kReportReferencePoses;
  std::vector<TimedPose> reference_;
  int64_t reference_stride_ = 1, reference_seen_ = 0;
  std::vector<RateSample> rate_;
  double rate_interval_ = 1.0;
  void sample_rate(std::chrono::steady_clock::time_point now);
  std::optional<CheckpointMeta> resumed_;  // the checkpoint this run continues
  std::string resume_warning_;             // a corrupt newest checkpoint, when the one before was used
  std::string checkpoint_names_;           // scratch for write_checkpoint()
  // preview.png's drawer (with preview or report on: its buffers are the plan's "map preview") and
  // the camera's path as mapped, for the preview written with each checkpoint (the final one is
  // drawn along trajectory.txt, whose poses a loop closure corrected).
  std::unique_ptr<MapPreviewer> previewer_;
  PreviewPath preview_path_;  // reserved with the previewer (empty without it)
  std::optional<Error> checkpoint_preview_error_;
  Status write_checkpoint_preview();
  std::string preview_title(int64_t frames) const;  // "<source>, N frames"
  int st_checkpoint_ = -1;
  int st_checkpoint_preview_ = -1;
  int st_log_map_ = -1;  // the map written into the field log at a checkpoint
  struct CounterIds {
    int camera_lost, corrupt_dropped, dropped_overload, surfels_created, surfels_removed, surfels_evicted,
        surfels_refused, cnn_skipped, realtime_late, checkpoint_previews_failed;
  } c_{};
};

}  // namespace ef::pipeline
