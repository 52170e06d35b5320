// The geometric core of the mapper: one object that takes frames at the working resolution and
// keeps the camera pose and the surfel map, ElasticFusion-style (Whelan et al., RSS 2015):
//
//   frame k ──preprocess──> pyramids (slam/preprocess.h)
//           ──track──────> T_world_cam(k), frame-to-model: the reference is the model predicted at
//                          the pose of the last tracked frame (slam/model_prediction.h), the guess
//                          is constant velocity (default) or "no motion" (ElasticFusion; option)
//           ──fuse───────> the surfel pool (slam/surfel_fusion.h), associating through the index map
//                          rendered at T_world_cam(k) just before (ElasticFusion; option
//                          associate_at_tracked_pose)
//           ──reorder────> every 30th fused frame, the pool regrouped by space (slam/spatial_order.h)
//           ──predict────> model maps + index map at T_world_cam(k), for frame k+1
//
// A lost frame (TrackResult::lost) is not fused and does not move the prediction. Its reported pose
// is the last good pose. With relocalisation (on by default) a lost frame is then encoded by
// randomised ferns (slam/keyframe_ferns.h) and aligned to the model predicted at each of the most
// similar keyframes' poses (the tracker, from that pose, at most relocalisation_candidates of them);
// the first that the tracker does not call lost gives its pose, and the frame is fused there. Every
// frame after a loss is tracked with care: from the last good pose (or the keyframe's) without the
// constant-velocity guess, and the motion across the gap is not taken as the next guess. Tracked
// frames that differ enough from every keyframe become keyframes. The first frame is fused at
// `initial_pose` (identity by default).
//
// Memory: create() sizes everything from the options (pool capacity, working resolution);
// process() does not touch the heap. Threads: one SurfelSlam per mapping thread.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "core/frame.h"
#include "core/intrinsics.h"
#include "core/result.h"
#include "core/se3.h"
#include "io/ply_writer.h"
#include "slam/deformation_graph.h"
#include "slam/keyframe_ferns.h"
#include "slam/pose_history.h"
#include "slam/model_prediction.h"
#include "slam/preprocess.h"
#include "slam/spatial_order.h"
#include "slam/surfel_fusion.h"
#include "slam/surfel_pool.h"
#include "slam/tracker.h"

namespace ef::slam {

struct SurfelSlamOptions {
  PreprocessOptions preprocess;
  TrackerOptions tracker;
  PredictionOptions prediction;
  FusionOptions fusion;
  SurfelPoolOptions pool;
  SpatialOrderOptions spatial_order;
  KeyframeFernOptions ferns;
  // Relocalisation of lost frames against the fern keyframes (see above). false: a lost frame is
  // tracked again from the last good pose only, and a camera that moved elsewhere stays lost.
  bool relocalisation = true;
  // Keyframes tried per lost frame, the most similar first (1..16). Each costs a model prediction
  // and a tracking (about 2 x 3 ms at 320x240), only on lost frames.
  int relocalisation_candidates = 3;
  // A frame the tracker accepts is still lost when its inlier fraction (TrackResult::inlier_fraction)
  // is below this fraction of the last fused frame's (once 10 frames were fused; while lost, that
  // reference relaxes by 5% a lost frame, so that a view the map covers less well is taken again
  // after a while and the absolute tests decide): the camera jumped and the tracker found a wrong
  // pose near the old one that the absolute tests pass (their thresholds must admit noisy cameras).
  // 0 = off. Measured frame to frame: 7-Scenes at least 0.95, a noisy synthetic inspecting scan at
  // least 0.92 (its fraction falls from 0.47 to 0.17 over its first 25 frames, steadily: an average
  // over 10 frames would lag and call frame 20 lost); a jump of 150 frames (87 cm) on 7-Scenes 0.38,
  // with an inlier fraction (0.24) and residual (9.6 mm) that the absolute tests accept.
  float lost_inlier_drop = 0.6f;
  // Loop closure (ElasticFusion, Whelan et al. RSS 2015 section 5): every loop_check_every-th fused
  // frame is registered (the tracker) against the inactive model, the surfels last seen more than
  // prediction.active_window_frames ago: first as seen from its own pose (local), else from the pose
  // of the most similar old keyframe (global). A registration the tracker accepts that moves the
  // camera by at least loop_min_correction_* (and less than the tracker's divergence limits) is a
  // closure: the deformation graph (slam/deformation_graph.h) is built from the pool, constrained to
  // carry the current view's surface (sampled every loop_sample_step pixels) onto the registered
  // place with the inactive surfels seen there pinned, optimised, and applied to every surfel (labels,
  // colour and confidence ride along), the current pose and the keyframes. A closure whose
  // constraints stay further than loop_max_residual_m (RMS) from met would tear the map: rejected.
  // The poses of the last pose_history frames are corrected too (slam/pose_history.h): `run`
  // rewrites trajectory.txt with them at the end, and the labels' late fusion uses them.
  bool loop_closure = true;
  int32_t pose_history = 54000;       // frames (30 minutes at 30 Hz), 0..10,000,000; only with loop_closure
  int loop_check_every = 10;          // fused frames, 1..1000
  // Below both, the map already meets itself: registering against the part of the view the
  // inactive model covers is itself uncertain by about a centimetre. Measured (docs/results.md): at
  // 1 cm / 1 degree, the eleven inspecting scans closed 3 loops of 1.0-1.4 cm, each making the ATE
  // worse (8.9 -> 10.6 mm, 7.0 -> 7.1 mm).
  float loop_min_correction_m = 0.02f;    // metres
  float loop_min_correction_deg = 2.0f;   // degrees
  float loop_max_residual_m = 0.01f;      // metres, RMS of the constraints after optimisation
  int loop_sample_step = 16;          // pixels of the working image between constraint samples
  DeformationGraphOptions graph;
  // Pose of the first frame, camera to world (metres). Default identity.
  SE3 initial_pose;
  // Fusion's data association: true = through an index map rendered at the frame's tracked pose
  // (ModelPredictor::render_index_map, ElasticFusion's order); false = through the index map of the
  // last prediction, rendered at the previous pose, which saves that render but sees nothing of the
  // map outside the previous view: surface entering the image at its border becomes new surfels
  // even where the map already holds it (duplicates on every revisit). Measured (docs/results.md,
  // SLAM): false leaves 16% more surfels at the end of 7-Scenes (425k against 367k) and 8-49% more
  // on 8 synthetic 1200-frame loops, for the same trajectory error and the same time per frame (the
  // smaller map makes association and prediction cheaper by about what the render costs).
  bool associate_at_tracked_pose = true;
  // Fusion associates with the active model only (surfels seen within
  // prediction.active_window_frames), as ElasticFusion: a revisit after the window creates new
  // surfels beside the old, inactive ones, which loop closure then registers against and deforms
  // onto. false (default): fusion associates with every surfel, so a revisit whose drift is within
  // fusion's gates updates the old surfels (and makes them active again) instead: the map absorbs
  // the drift, and loop closure only acts where the drift exceeds the gates. Measured on 7-Scenes
  // (docs/results.md): true gives 11 local closures and ATE 2.73 cm with 477k surfels, false none,
  // 2.66 cm and 367k surfels; on the 2000-frame synthetic loop 12.6 mm against 5.7 mm.
  bool associate_active_only = false;
  // Initial guess of each frame's pose: false = the last tracked pose (ElasticFusion), true = the last
  // pose times the last inter-frame motion (constant velocity). Why true: a hand-held camera moves
  // smoothly, and starting from the last pose leaves a whole frame's motion (7 mm and 2 degrees on
  // the inspecting synthetic scans) for the coarse levels to find, where a view of a near wall lets
  // them slip to a wrong minimum. Measured (docs/results.md, SLAM, "Tracking a close inspecting
  // scan"): 7-Scenes ATE 2.66 cm either way; the eleven synthetic scans all within 11.5 mm against
  // up to 237 mm with the last pose (with the tracker's photometric boost at its default).
  bool constant_velocity_guess = true;
  // Until surfels can reach the stable confidence (it takes about that many observations), the
  // tracking prediction admits surfels with confidence >= this fraction of the frames fused so far
  // (dimensionless, 0..1], capped at the stable threshold. 0.5: a surfel seen in half the frames.
  float bootstrap_confidence_per_frame = 0.5f;
  // true: the SLAM has its own Preprocessor for process(frame). false: frames only come already
  // preprocessed, through process(frame, preprocessed) (a pipeline that preprocesses on another
  // thread); saves the pyramids' memory (Preprocessor::bytes(), 4.7 MB at 320x240).
  bool own_preprocessor = true;

  // The keys `run` offers (section mapping): constant_velocity_guess, associate_at_tracked_pose,
  // relocalisation, lost_inlier_drop, loop_closure, associate_active_only, loop_check_every,
  // loop_min_correction_m / _deg, loop_max_residual_m, relocalisation_candidates, loop_sample_step.
  // Those of the parts are in their own tables (PreprocessOptions::table(), ...).
  static const opt::Table<SurfelSlamOptions>& table();
  Status validate() const;
  std::string describe() const;
};

// Milliseconds per stage of the last process() call (steady clock).
// fuse_ms includes index_ms, the index map rendered at the tracked pose for fusion's association
// (0 with associate_at_tracked_pose false and on the first frame), and reorder_ms: the spatial
// reordering of the pool (slam/spatial_order.h) on the frames it is due, 0 on the others.
// relocalise_ms: the fern lookup and the tracking against keyframes of a lost frame (0 on others);
// keyframe_ms: encoding a tracked frame and its novelty test against the keyframes.
// loop_ms: the loop-closure check (inactive predictions and registrations; 0 on frames without one)
// and, on a closure, the graph's build, optimisation and application.
struct SlamTimings {
  double preprocess_ms = 0, track_ms = 0, fuse_ms = 0, index_ms = 0, reorder_ms = 0, predict_ms = 0,
         relocalise_ms = 0, keyframe_ms = 0, loop_ms = 0, total_ms = 0;
};

// Where a loop closure registered the frame: against the inactive model at the frame's own pose
// (local) or at an old keyframe's (global).
enum class LoopKind { kNone, kLocal, kGlobal };
const char* loop_kind_name(LoopKind kind);  // "none", "local", "global"

struct SlamFrameResult {
  SE3 T_world_cam;       // the frame's pose (the last good pose when lost)
  bool lost = false;     // tracking failed: not fused (track.reason says why)
  bool fused = false;
  bool relocalised = false;   // lost before, found again against keyframe `keyframe` (or tracked again
                              // from the last good pose: keyframe -1) and fused
  int32_t keyframe = -1;
  int64_t lost_before = 0;    // frames lost in a row before this one, on the frame that resumes
  TrackLostReason tracking_lost = TrackLostReason::kNone;  // a frame found at a keyframe: why tracking
                                                           // from the last good pose failed on it
  bool new_keyframe = false;  // this frame became a keyframe
  // Loop closure on this frame: none, local or global; accepted or rejected (see
  // SurfelSlamOptions::loop_closure); the deformation's figures when one was optimised.
  bool loop_registered = false;  // the check registered the frame against the inactive model
  LoopKind loop_kind = LoopKind::kNone;
  bool loop_accepted = false;
  double loop_correction_m = 0;  // how far the registration moved the camera, metres
  DeformationResult deformation;
  TrackResult track;     // meaningless for the first frame (nothing to track against); a relocalised
                         // frame's is relative to its keyframe's pose
  FusionStats fusion;    // zero when not fused
  SlamTimings timings;
};

class SurfelSlam {
 public:
  // working: intrinsics of the frames process() will get (the working resolution).
  static Result<SurfelSlam> create(const Intrinsics& working, const SurfelSlamOptions& options = {});

  // Processes one frame at the working resolution (depth in metres, colour optional).
  // Errors (kInvalidArgument): a frame of another size, or a SLAM created without its own
  // preprocessor (options.own_preprocessor false). Lost tracking is not an error.
  Status process(const Frame& frame, SlamFrameResult* result);
  // The same for a frame whose pyramids `preprocessed` already holds (it processed `frame` last):
  // preprocessing needs nothing from the map, so a pipeline runs it on another thread, ahead of
  // tracking, with a Preprocessor of its own per frame slot (made by make_preprocessor()). The
  // result's timings.preprocess_ms is then 0. Errors (kInvalidArgument): a frame or a preprocessor
  // of another size or level count.
  Status process(const Frame& frame, const Preprocessor& preprocessed, SlamFrameResult* result);
  // A Preprocessor with this SLAM's intrinsics and options, for process(frame, preprocessed, ...).
  Result<Preprocessor> make_preprocessor() const;

  // What carries from one frame to the next besides the pool's surfels: with the pool, the whole
  // state a checkpoint saves (pipeline/checkpoint.h).
  struct State {
    SE3 T_world_last;                     // the last good pose
    SE3 last_motion;                      // the constant-velocity guess
    int64_t frames = 0, fused_frames = 0, lost_frames = 0;
    int64_t sweep_cursor = 0;             // SurfelFusion's lifetime sweep
    int32_t predicted_frame = 0;          // the frame index and confidence gate of the last prediction
    float predicted_min_confidence = 0;
    int64_t lost_run = 0;                 // frames lost in a row up to now
    int64_t relocalisations = 0;
    double inlier_reference = 0;          // the last fused frame's inlier fraction (lost_inlier_drop)
    int64_t inlier_samples = 0;
  };
  State state() const;
  // Continues from a checkpoint: the pool was filled first (SurfelPool::set_restored through
  // pool_for_restore()); this takes `state` and renders the prediction the SLAM had then, so the
  // next frame is tracked as it would have been without the interruption. Errors: the predictor's.
  Status restore(const State& state);
  SurfelPool& pool_for_restore() { return pool_; }

  const SurfelPool& pool() const { return pool_; }
  // The pool for the semantic layer (semantic/label_fusion.h, the dense CRF), which writes only the
  // label column between process() calls. Geometry must not be changed outside process(): the
  // predictor's index map refers to the pool as process() left it.
  SurfelPool& pool_for_labels() { return pool_; }
  const SE3& pose() const { return T_world_last_; }  // last good pose
  int64_t frames() const { return frames_; }
  int64_t lost_frames() const { return lost_frames_; }
  const SurfelSlamOptions& options() const { return options_; }
  const ModelPredictor& predictor() const { return predictor_; }
  // The predictor with its index map drawn at the last prediction's pose from every surfel (the map
  // as it is after the last processed frame, seen from that frame's pose), drawing it now when the
  // prediction left it out. For label fusion and rendering between process() calls.
  const ModelPredictor& predictor_with_index_map() {
    predictor_.draw_index_map_at_prediction(pool_);
    return predictor_;
  }
  const KeyframeFerns& keyframes() const { return ferns_; }
  KeyframeFerns& keyframes_for_restore() { return ferns_; }
  // Every frame's pose (the last options.pose_history frames), corrected by each loop closure;
  // empty without loop closure.
  const PoseHistory& pose_history() const { return history_; }
  PoseHistory& pose_history_for_restore() { return history_; }
  int64_t relocalisations() const { return relocalisations_; }
  struct LoopCounters {
    int64_t local_accepted = 0, local_rejected = 0, global_accepted = 0, global_rejected = 0;
  };
  const LoopCounters& loop_counters() const { return loops_; }
  // The confidence a surfel needs to enter the tracking maps now (grows with the frames fused).
  float tracking_min_confidence() const;

  // Bytes allocated by create(), by part (for the memory budget).
  std::size_t pool_bytes() const { return pool_.bytes(); }
  std::size_t spatial_order_bytes() const { return order_.bytes(); }
  std::size_t keyframe_bytes() const { return ferns_.bytes(); }
  std::size_t deformation_bytes() const { return graph_ ? graph_->bytes() : 0; }
  std::size_t pose_history_bytes() const { return history_.bytes(); }

 private:
  Status track_fuse_predict(const Frame& frame, const Preprocessor& pre, SlamFrameResult* result);
  // Tries the keyframes most like `frame`; on success fills result->track (relative to the keyframe),
  // result->keyframe and *T_world_cur. Leaves the predictor at another pose (prediction_stale_).
  Status relocalise(const Frame& frame, const Preprocessor& pre, SlamFrameResult* result, SE3* T_world_cur);
  // The loop-closure check of a fused frame (see SurfelSlamOptions::loop_closure); may deform the
  // pool and move *T_world_cur. Leaves the predictor at another pose (the caller predicts next).
  Status check_loop(const Preprocessor& pre, int32_t frame_index, SlamFrameResult* result, SE3* T_world_cur);
  // Registers the frame against the inactive model rendered at T_ref (guess: T_ref^-1 T_world_cur);
  // true with *T_loop when the tracker accepts it.
  Status register_inactive(const Preprocessor& pre, const SE3& T_ref, const SE3& T_world_cur, int32_t seen_before,
                           bool* ok, SE3* T_loop);
  SurfelSlam(SurfelSlamOptions options, const Intrinsics& working, std::optional<Preprocessor> pre, Tracker tracker,
             ModelPredictor predictor, SurfelFusion fusion, SurfelPool pool, SpatialOrder order, KeyframeFerns ferns,
             std::optional<DeformationGraph> graph, PoseHistory history)
      : options_(std::move(options)),
        working_(working),
        pre_(std::move(pre)),
        tracker_(std::move(tracker)),
        predictor_(std::move(predictor)),
        fusion_(std::move(fusion)),
        pool_(std::move(pool)),
        order_(std::move(order)),
        ferns_(std::move(ferns)),
        code_(ferns_.make_code()),
        graph_(std::move(graph)),
        history_(std::move(history)) {}

  SurfelSlamOptions options_;
  Intrinsics working_;                // the working resolution's intrinsics
  std::optional<Preprocessor> pre_;   // only with options_.own_preprocessor
  Tracker tracker_;
  ModelPredictor predictor_;
  SurfelFusion fusion_;
  SurfelPool pool_;
  SpatialOrder order_;
  KeyframeFerns ferns_;
  FernCode code_;            // the current frame's encoding (sized once)
  std::optional<DeformationGraph> graph_;  // only with options_.loop_closure
  PoseHistory history_;      // capacity 0 without loop closure
  LoopCounters loops_;
  bool prediction_stale_ = false;  // relocalisation left the predictor at a keyframe's pose
  int64_t lost_run_ = 0;     // frames lost in a row
  int64_t relocalisations_ = 0;
  double inlier_reference_ = 0;  // the last fused frame's inlier fraction (lost_inlier_drop)
  int64_t inlier_samples_ = 0;
  // The tracker accepted `t`, but its inliers fell far below the recent frames' (lost_inlier_drop).
  bool inliers_dropped(const TrackResult& t) const;
  SE3 T_world_last_;         // pose of the last good frame = the pose the prediction was rendered at
  SE3 last_motion_;          // T_prev_cur of the last good frame pair (constant velocity guess)
  int64_t frames_ = 0;
  int64_t fused_frames_ = 0;
  int64_t lost_frames_ = 0;
  int32_t predicted_frame_ = 0;          // arguments of the last predictor_.predict()
  float predicted_min_confidence_ = 0;
};

// A view of the pool for io/ply_writer.h (colours from the packed column). The class columns are
// left empty (written as zeros); the caller fills them from the label store (semantic/label_store.h).
SurfelCloudView surfel_cloud_view(const SurfelPool& pool);

}  // namespace ef::slam
