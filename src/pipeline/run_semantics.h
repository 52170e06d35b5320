// The semantic half of `edgefusion run` (SemanticFusion, McCormac et al. ICRA 2017), in two parts
// that run on different threads of the pipeline (pipeline/run_pipeline.h):
//   CNN, segment()               the network on a copy of a working frame (pipeline/cnn_worker.h:
//                                on a thread of its own, or at once with one pipeline thread);
//                                segmentation needs no pose, so it runs beside tracking
//   mapping step, on_frame()     after the surfel SLAM tracked frame n: every CNN result that is done
//                                for a frame up to n is fused at its own frame's pose: frame n's
//                                through the index map SLAM rendered at n's pose, an earlier frame's
//                                (the CNN finished late) through an index map rendered here at that
//                                frame's pose; results of lost frames are not fused (counted);
//                                the CNN probabilities multiply into every surfel the index map
//                                shows (semantic/label_fusion.h);
//                                every crf_every-th frame the dense CRF over the map (semantic/dense_crf.h);
//                                every labels_out_every-th frame the map's labels rendered into the
//                                frame's view, with the CNN's own prediction where no labelled surfel
//                                is seen (semantic/label_render.h), written as DIR/<frame name>.png
//                                (those frames always wait for their CNN result)
//   at the end, drain(), finish()  the results still in flight fused; the CRF once more if
//                                crf_final; map.ply's class columns.
// Memory: create() allocates everything (segmenter, fusion buffers, a predictor for late results'
// index maps, the pose history, CRF lattice, the rendered image, the class columns of map.ply);
// allocate() sizes each CnnResult once; segment() and on_frame() allocate only inside libpng when a
// label image is written.
// Threads: segment() uses only the segmenter and may run on one thread while on_frame() runs on
// another; each of them on one thread at a time.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/frame.h"
#include "core/image.h"
#include "core/intrinsics.h"
#include "core/result.h"
#include "io/mcap_log.h"
#include "core/stage_stats.h"
#include "io/ply_writer.h"
#include "pipeline/run_config.h"
#include "semantic/dense_crf.h"
#include "semantic/label_fusion.h"
#include "semantic/segmenter.h"
#include "slam/surfel_slam.h"

namespace ef::pipeline {

class CnnWorker;
struct CnnJob;

// What the semantics step takes of a run's configuration (semantics_options(config)).
struct SemanticsOptions {
  LabelOptions labels;                  // the network and the label images
  semantic::LabelFusionOptions fusion;  // its image sizes are set by create()
  CrfOptions crf;                       // when the dense CRF runs
  semantic::DenseCrfOptions dense_crf;  // sized by crf_options_for_run
  int64_t pool_capacity = 0;            // surfels: map.ply's class columns
  slam::PredictionOptions prediction;   // the mapping's: late results' index maps are rendered alike
  std::string source;                   // the run's source URI: which shipped model is the default
};
// crf_nodes: the CRF's capacity (MemoryPlan::crf_nodes: what `run` plans); 0 = crf.capacity or the
// pool's (crf_options_for_run).
SemanticsOptions semantics_options(const RunConfig& config, int64_t crf_nodes = 0);

// The folder of labels.out's palette images: "<labels.out>_color" beside it (out/labels ->
// out/labels_color, as `segment` names its two folders).
std::string color_label_folder(const std::string& labels_out);

// DIR/<frame name>.png, the label image of `frame` (its index, 6 digits, where it has no name): the
// names `edgefusion convert --to tum:` gives its labels, so `edgefusion eval labels` pairs them.
std::string label_image_path(const std::string& dir, const Frame& frame);

// The CNN's result for one frame, carried with the frame from the segment step to the mapping step.
struct CnnResult {
  bool valid = false;                // the CNN ran on this frame
  std::vector<float> probabilities;  // output height x width x classes (semantic::ProbabilityView)
  int width = 0, height = 0, classes = 0;
  Image<uint8_t> labels;             // its class ids at the working size (the rendering's fallback)
  double segment_ms = 0;             // time the CNN took, milliseconds
  semantic::ProbabilityView view() const { return {probabilities.data(), height, width, classes}; }
  // Bytes of the probabilities and the class ids (what allocate() sized).
  std::size_t bytes() const { return probabilities.size() * sizeof(float) + labels.size(); }
  // What RunSemantics::allocate() sizes for a CNN output of width x height x classes and a working
  // image of working_width x working_height.
  static std::size_t bytes_for(int width, int height, int classes, int working_width, int working_height) {
    return std::size_t(width) * std::size_t(height) * std::size_t(classes) * sizeof(float) +
           std::size_t(working_width) * std::size_t(working_height);
  }
};

class RunSemantics {
 public:
  // The stages it records into StageStats (segment, label_fuse, label_render, crf).
  static constexpr const char* kStageNames[] = {"segment", "label_fuse", "label_render", "crf"};

  // Loads the model (options.labels.model or the shipped one), sizes every buffer for `working`
  // and a pool of options.pool_capacity surfels, registers its stages and counters in `stats`, and
  // creates the label folders. Errors name the model file or the folder.
  static Result<std::unique_ptr<RunSemantics>> create(const SemanticsOptions& options, const Intrinsics& working,
                                                      StageStats& stats);
  // The model a run of `labels` on `source_uri` loads: labels.model, or the shipped one for that
  // source when it is empty (model_paths.h).
  static std::string model_path(const LabelOptions& labels, const std::string& source_uri);
  // Bytes create() allocates besides the segmenter: the rendered image at the working size and
  // map.ply's class columns (5 bytes per surfel of capacity).
  static std::size_t rendering_bytes_for(int working_width, int working_height);
  // Bytes of what late results need: the predictor that renders their index maps and the pose history.
  static std::size_t late_fusion_bytes_for(int working_width, int working_height,
                                           const slam::PredictionOptions& prediction);
  // Poses of the last frames kept for late results; a result older than this is not fused (counted).
  // A loop closure replaces them by the SLAM's corrected ones (slam/pose_history.h).
  static constexpr int kPoseHistory = 256;
  // The label fusion create() makes: options.fusion for a working image of working_width x
  // working_height and a CNN output of cnn_width x cnn_height (also what the memory plan sizes).
  static semantic::LabelFusionOptions fusion_options(const SemanticsOptions& options, int working_width,
                                                     int working_height, int cnn_width, int cnn_height);
  static std::size_t class_column_bytes_for(int64_t pool_capacity);

  // Whether frame `frame_number` is due for a label update (every label_every-th frame) and for a
  // label image (every labels_out_every-th with labels.out set): the front stage's requests to the CNN.
  bool fusion_due(int64_t frame_number) const;
  bool image_due(int64_t frame_number) const;
  // Sizes `out` for this model and working size (start-up; allocates).
  void allocate(CnnResult& out) const;
  // The CNN: segments `working` (the working size) into `out` (sized by allocate()).
  Status segment(const Frame& working, CnnResult& out);

  // Mapping stage, after slam.process() of frame `frame_number` (see the header). wait_for_this:
  // the CNN has this frame queued and the mapping waits for its result (label images; deterministic runs).
  Status on_frame(int64_t frame_number, const Frame& working, bool wait_for_this, const slam::SlamFrameResult& result,
                  slam::SurfelSlam& slam, CnnWorker& worker);
  // After the last mapped frame `last_frame`: waits for the CNN's results for frames up to it and
  // fuses them at their poses.
  Status drain(int64_t last_frame, slam::SurfelSlam& slam, CnnWorker& worker);
  // The last result fused: its frame, the frame being mapped when it was fused, and the pose used
  // (tests check that every result meets its own frame's pose).
  struct FusedResult {
    int64_t frame = -1, fused_at = -1;
    SE3 T_world_cam;
  };
  const FusedResult& last_fused() const { return last_fused_; }
  // At the end of the run, before the map is written: the final CRF if asked for.
  Status finish(slam::SurfelSlam& slam);
  // Fills `view`'s class_id and class_prob columns from the pool's label store.
  void add_label_columns(const slam::SurfelPool& pool, SurfelCloudView& view);

  // "model edgefusion-seg.efm (160x120 -> 14 classes), labels every 10 frames, CRF off" for the log.
  std::string describe() const;
  // The measured depth for the visibility test, or the empty view when it is off (LabelFusion).
  ImageView<const float> visible_depth(ImageView<const float> depth) const { return fusion_->visible_depth(depth); }
  const LabelOptions& labels() const { return options_.labels; }
  const semantic::LabelFusion& fusion() const { return *fusion_; }
  const semantic::Segmenter& segmenter() const { return *segmenter_; }
  // Bytes of what late results need (late_fusion_bytes_for).
  std::size_t late_fusion_bytes() const { return label_view_->bytes() + poses_.size() * sizeof(PoseRecord); }

  // The field log (null: none) and the mapping thread's encoder (images of the working size), both
  // borrowed: each CNN result taken is written as a class-id PNG at its frame's timestamp.
  void set_log(McapFrameLog* log, McapFrameLog::Encoder* encoder) {
    log_ = log;
    log_encoder_ = encoder;
  }

 private:
  void log_labels(const CnnJob& job);  // into the field log, when there is one
  RunSemantics() = default;
  Status write_rendering(const Frame& working, const CnnResult& cnn, const slam::SlamFrameResult& result,
                         slam::SurfelSlam& slam);
  // Fuses `job` (done, no error) while mapping frame `now`: at the current index map when it is
  // that frame's, else through label_view_ rendered at its frame's pose.
  Status fuse_job(const CnnJob& job, int64_t now, const Frame* working, const slam::SlamFrameResult* result,
                  slam::SurfelSlam& slam);
  struct PoseRecord {
    int64_t frame = -1;
    SE3 T_world_cam;
    bool lost = true;
  };
  Status run_crf(slam::SurfelSlam& slam);

  SemanticsOptions options_;
  std::string model_path_;
  std::unique_ptr<semantic::Segmenter> segmenter_;
  std::unique_ptr<semantic::LabelFusion> fusion_;
  std::unique_ptr<semantic::DenseCrf> crf_;  // null when neither crf_every nor crf_final
  std::optional<slam::ModelPredictor> label_view_;  // index maps of late results
  std::vector<PoseRecord> poses_;            // kPoseHistory, by frame number modulo
  FusedResult last_fused_;
  McapFrameLog* log_ = nullptr;
  McapFrameLog::Encoder* log_encoder_ = nullptr;
  Image<uint8_t> rendered_;                  // the map's labels at the working size
  Image<Rgb8> rendered_color_;               // the same in the paper's palette (labels.out's _color folder)
  std::vector<uint8_t> class_id_;            // map.ply columns, one per pool slot
  std::vector<float> class_prob_;
  StageStats* stats_ = nullptr;
  int st_segment_ = -1, st_fuse_ = -1, st_render_ = -1, st_crf_ = -1;
  int c_cnn_frames_ = -1, c_surfel_updates_ = -1, c_hidden_ = -1, c_no_depth_ = -1, c_label_images_ = -1;
  int c_crf_runs_ = -1, c_crf_left_out_ = -1, c_crf_unconfident_ = -1, c_crf_beyond_ = -1;
  int c_late_ = -1, c_unfused_ = -1;
  int64_t last_crf_frame_ = -1;
};

}  // namespace ef::pipeline
