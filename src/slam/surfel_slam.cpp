#include "slam/surfel_slam.h"

#include "core/stopwatch.h"

#include <algorithm>
#include <chrono>
#include <sstream>

namespace ef::slam {

namespace {
using Clock = SteadyClock;
}  // namespace

const opt::Table<SurfelSlamOptions>& SurfelSlamOptions::table() {
  static const opt::Table<SurfelSlamOptions> t = {
      {"constant_velocity_guess", "constant_velocity_guess", "", &SurfelSlamOptions::constant_velocity_guess, "",
       opt::any(), "tracking starts each frame from the last pose times the last motion; false = from the last pose (ElasticFusion)"},
      {"associate_at_tracked_pose", "associate_at_tracked_pose", "", &SurfelSlamOptions::associate_at_tracked_pose, "",
       opt::any(),
       "fusion associates each frame through an index map rendered at its tracked pose (ElasticFusion); false = the "
       "previous pose's, one render less per frame but duplicate surfels wherever known surface enters the view"},
      {"relocalisation", "", "", &SurfelSlamOptions::relocalisation, "", opt::any(),
       "a lost frame is looked up among the fern keyframes and tracked against the model at the most similar ones' "
       "poses; false = tracked again from the last good pose only"},
      {"lost_inlier_drop", "", "", &SurfelSlamOptions::lost_inlier_drop, "fraction", opt::between(0, 1),
       "a tracked frame is lost when its inlier fraction falls below this fraction of the recent frames' (a jumped "
       "camera tracked to a wrong pose); 0 = off"},
      {"relocalisation_candidates", "", "", &SurfelSlamOptions::relocalisation_candidates, "keyframes",
       opt::between(1, 16), "keyframes tried per lost frame, the most similar first"},
  };
  return t;
}

Status SurfelSlamOptions::validate() const {
  EF_RETURN_IF_ERROR(preprocess.validate());
  EF_RETURN_IF_ERROR(tracker.validate());
  EF_RETURN_IF_ERROR(prediction.validate());
  EF_RETURN_IF_ERROR(fusion.validate());
  EF_RETURN_IF_ERROR(pool.validate());
  EF_RETURN_IF_ERROR(spatial_order.validate());
  EF_RETURN_IF_ERROR(ferns.validate());
  EF_RETURN_IF_ERROR(opt::check_table(*this, table(), "slam"));
  if (fusion.stable_confidence != prediction.stable_confidence)
    return error(ErrorCode::kInvalidArgument,
                 "slam: fusion.stable_confidence " + std::to_string(fusion.stable_confidence) +
                     " differs from prediction.stable_confidence " + std::to_string(prediction.stable_confidence) +
                     " (one threshold decides which surfels are stable)");
  if (fusion.normal_level >= preprocess.levels)
    return error(ErrorCode::kInvalidArgument, "slam: fusion.normal_level " + std::to_string(fusion.normal_level) +
                                                  " needs preprocess.levels > it (levels " +
                                                  std::to_string(preprocess.levels) + ")");
  if (!(bootstrap_confidence_per_frame > 0.0f && bootstrap_confidence_per_frame <= 1.0f))
    return error(ErrorCode::kInvalidArgument, "slam: bootstrap_confidence_per_frame " +
                                                  std::to_string(bootstrap_confidence_per_frame) +
                                                  " is outside (0, 1]");
  return Status::success();
}

std::string SurfelSlamOptions::describe() const {
  std::ostringstream s;
  s << "# preprocess\n" << preprocess.describe() << "# tracker\n" << tracker.describe() << "# prediction\n"
    << prediction.describe() << "# fusion\n" << fusion.describe() << "# pool\n" << pool.describe()
    << "# spatial order\n" << spatial_order.describe() << "# keyframe ferns\n" << ferns.describe()
    << "relocalisation: " << (relocalisation ? "true" : "false") << "  # lost frames looked up among the keyframes\n"
    << "relocalisation_candidates: " << relocalisation_candidates << "  # keyframes tried per lost frame\n"
    << "associate_at_tracked_pose: " << (associate_at_tracked_pose ? "true" : "false")
    << "  # fusion associates through an index map at the tracked pose (false: the previous pose's)\n"
    << "constant_velocity_guess: " << (constant_velocity_guess ? "true" : "false")
    << "  # initial guess: last pose (false) or constant velocity (true)\n"
    << "bootstrap_confidence_per_frame: " << bootstrap_confidence_per_frame
    << "  # early tracking admits surfels with confidence >= this x frames fused\n"
    << "own_preprocessor: " << (own_preprocessor ? "true" : "false")
    << "  # false: frames come preprocessed (process(frame, preprocessed))\n";
  return s.str();
}

Result<SurfelSlam> SurfelSlam::create(const Intrinsics& working, const SurfelSlamOptions& options) {
  EF_RETURN_IF_ERROR(options.validate());
  std::optional<Preprocessor> pre;
  if (options.own_preprocessor) {
    EF_ASSIGN_OR_RETURN(Preprocessor own, Preprocessor::create(working, options.preprocess));
    pre.emplace(std::move(own));
  }
  EF_ASSIGN_OR_RETURN(Tracker tracker, Tracker::create(working, options.preprocess.levels, options.tracker));
  EF_ASSIGN_OR_RETURN(ModelPredictor predictor,
                      ModelPredictor::create(working, options.preprocess.levels, options.prediction));
  EF_ASSIGN_OR_RETURN(SurfelFusion fusion, SurfelFusion::create(working, options.prediction.index_map_scale,
                                                                options.pool.capacity, options.fusion));
  EF_ASSIGN_OR_RETURN(SurfelPool pool, SurfelPool::create(options.pool));
  EF_ASSIGN_OR_RETURN(SpatialOrder order, SpatialOrder::create(options.pool.capacity, options.spatial_order));
  EF_ASSIGN_OR_RETURN(KeyframeFerns ferns, KeyframeFerns::create(working.width, working.height, options.ferns));
  SurfelSlam slam(options, working, std::move(pre), std::move(tracker), std::move(predictor), std::move(fusion),
                  std::move(pool), std::move(order), std::move(ferns));
  slam.T_world_last_ = options.initial_pose;
  // An empty index map at the initial pose: the first frame finds no candidates and creates surfels.
  slam.predicted_frame_ = 0;
  slam.predicted_min_confidence_ = options.prediction.stable_confidence;
  EF_RETURN_IF_ERROR(slam.predictor_.predict(slam.pool_, slam.T_world_last_, 0, options.prediction.stable_confidence));
  return slam;
}

SurfelSlam::State SurfelSlam::state() const {
  State s;
  s.T_world_last = T_world_last_;
  s.last_motion = last_motion_;
  s.frames = frames_;
  s.fused_frames = fused_frames_;
  s.lost_frames = lost_frames_;
  s.sweep_cursor = fusion_.sweep_cursor();
  s.predicted_frame = predicted_frame_;
  s.predicted_min_confidence = predicted_min_confidence_;
  s.lost_run = lost_run_;
  s.relocalisations = relocalisations_;
  s.inlier_average = inlier_average_;
  s.inlier_samples = inlier_samples_;
  return s;
}

Status SurfelSlam::restore(const State& s) {
  T_world_last_ = s.T_world_last;
  last_motion_ = s.last_motion;
  frames_ = s.frames;
  fused_frames_ = s.fused_frames;
  lost_frames_ = s.lost_frames;
  fusion_.set_sweep_cursor(s.sweep_cursor);
  predicted_frame_ = s.predicted_frame;
  predicted_min_confidence_ = s.predicted_min_confidence;
  lost_run_ = s.lost_run;
  relocalisations_ = s.relocalisations;
  inlier_average_ = s.inlier_average;
  inlier_samples_ = s.inlier_samples;
  prediction_stale_ = false;
  return predictor_.predict(pool_, T_world_last_, predicted_frame_, predicted_min_confidence_);
}

float SurfelSlam::tracking_min_confidence() const {
  const float ramp = options_.bootstrap_confidence_per_frame * static_cast<float>(fused_frames_);
  return std::min(options_.prediction.stable_confidence, ramp);
}

Result<Preprocessor> SurfelSlam::make_preprocessor() const {
  return Preprocessor::create(working_, options_.preprocess);
}

Status SurfelSlam::process(const Frame& frame, SlamFrameResult* result) {
  if (!pre_)
    return error(ErrorCode::kInvalidArgument,
                 "slam: created without its own preprocessor (own_preprocessor = false): frames must come "
                 "preprocessed, through process(frame, preprocessed, result)");
  const Clock::time_point t_start = Clock::now();
  EF_RETURN_IF_ERROR(pre_->process(frame));
  const double preprocess_ms = ms_since(t_start);
  EF_RETURN_IF_ERROR(track_fuse_predict(frame, *pre_, result));
  result->timings.preprocess_ms = preprocess_ms;
  result->timings.total_ms = ms_since(t_start);
  return Status::success();
}

Status SurfelSlam::process(const Frame& frame, const Preprocessor& preprocessed, SlamFrameResult* result) {
  const Intrinsics& k = working_;
  const Intrinsics& p = preprocessed.intrinsics();
  const int levels = options_.preprocess.levels;
  if (p.width != k.width || p.height != k.height || preprocessed.levels() != levels)
    return error(ErrorCode::kInvalidArgument,
                 "slam: preprocessed frame is " + std::to_string(p.width) + "x" + std::to_string(p.height) + " with " +
                     std::to_string(preprocessed.levels()) + " levels; the SLAM works at " + std::to_string(k.width) +
                     "x" + std::to_string(k.height) + " with " + std::to_string(levels));
  if (frame.depth.width() != k.width || frame.depth.height() != k.height)
    return error(ErrorCode::kInvalidArgument, "slam: frame is " + std::to_string(frame.depth.width()) + "x" +
                                                  std::to_string(frame.depth.height()) + "; the SLAM works at " +
                                                  std::to_string(k.width) + "x" + std::to_string(k.height));
  return track_fuse_predict(frame, preprocessed, result);
}

Status SurfelSlam::track_fuse_predict(const Frame& frame, const Preprocessor& pre, SlamFrameResult* result) {
  const Clock::time_point t_start = Clock::now();
  *result = SlamFrameResult{};
  const auto frame_index = static_cast<int32_t>(frames_);
  Clock::time_point t0;

  // Track against the model predicted at the last good pose (none for the first frame).
  SE3 T_world_cur = T_world_last_;
  const bool after_loss = lost_run_ > 0;
  if (fused_frames_ > 0) {
    if (prediction_stale_) {
      // A failed relocalisation left the predictor at a keyframe's pose.
      t0 = Clock::now();
      EF_RETURN_IF_ERROR(predictor_.predict(pool_, T_world_last_, predicted_frame_, predicted_min_confidence_));
      prediction_stale_ = false;
      result->timings.relocalise_ms += ms_since(t0);
    }
    // With care after a loss: the motion before it says nothing about where the camera is now.
    const SE3 guess = options_.constant_velocity_guess && !after_loss ? last_motion_ : SE3();
    t0 = Clock::now();
    EF_RETURN_IF_ERROR(tracker_.track(predictor_.pyramid_view(), pyramid_view(pre), guess, &result->track));
    result->timings.track_ms = ms_since(t0);
    if (inliers_dropped(result->track)) {
      result->track.lost = true;
      result->track.reason = TrackLostReason::kInliersDropped;
    }
    if (!result->track.lost) {
      T_world_cur = T_world_last_ * result->track.T_ref_cur;
    } else if (options_.relocalisation && ferns_.size() > 0 && result->track.reason != TrackLostReason::kNoData) {
      t0 = Clock::now();
      result->tracking_lost = result->track.reason;
      EF_RETURN_IF_ERROR(relocalise(frame, pre, result, &T_world_cur));
      result->timings.relocalise_ms += ms_since(t0);
    }
    if (result->track.lost) {
      result->lost = true;
      ++lost_frames_;
      ++lost_run_;
    } else if (after_loss || result->keyframe >= 0) {
      result->relocalised = true;
      result->lost_before = lost_run_;
      ++relocalisations_;
      lost_run_ = 0;
    }
  } else {
    result->track.lost = false;
    result->track.reason = TrackLostReason::kNone;
  }
  result->T_world_cam = T_world_cur;

  if (!result->lost) {
    // Fuse through an index map at the tracked pose (or the last prediction's, at the last good
    // pose), then predict at the new pose.
    t0 = Clock::now();
    if (options_.associate_at_tracked_pose && fused_frames_ > 0) {
      predictor_.render_index_map(pool_, T_world_cur);
      result->timings.index_ms = ms_since(t0);
    }
    EF_RETURN_IF_ERROR(fusion_.fuse(pre, frame.color.view(), T_world_cur, predictor_.index_map(), frame_index,
                                    &pool_, &result->fusion));
    if (order_.due(fused_frames_)) {
      // Between fusion and prediction: the index map is then rendered from the reordered ids.
      const Clock::time_point t1 = Clock::now();
      EF_RETURN_IF_ERROR(order_.reorder(pool_));
      result->timings.reorder_ms = ms_since(t1);
    }
    result->timings.fuse_ms = ms_since(t0);
    result->fused = true;
    ++fused_frames_;
    // Not across a gap, nor from a keyframe's pose: the next frame starts from no motion.
    if (frames_ > 0) last_motion_ = after_loss || result->keyframe >= 0 ? SE3() : result->track.T_ref_cur;
    T_world_last_ = T_world_cur;

    if (frames_ > 0) {
      const double f = result->track.inlier_fraction;
      inlier_average_ = inlier_samples_ == 0 ? f : 0.9 * inlier_average_ + 0.1 * f;
      ++inlier_samples_;
    }
    // A new view becomes a keyframe (ferns of the raw frame; a relocalised frame too).
    t0 = Clock::now();
    ferns_.encode(frame.depth.view(), frame.color.view(), &code_);
    result->new_keyframe = ferns_.add_if_novel(code_, T_world_cur, frame_index) >= 0;
    result->timings.keyframe_ms = ms_since(t0);

    t0 = Clock::now();
    predicted_frame_ = frame_index;
    predicted_min_confidence_ = tracking_min_confidence();
    EF_RETURN_IF_ERROR(predictor_.predict(pool_, T_world_cur, frame_index, predicted_min_confidence_));
    prediction_stale_ = false;
    result->timings.predict_ms = ms_since(t0);
  }
  ++frames_;
  result->timings.total_ms = ms_since(t_start);
  return Status::success();
}

bool SurfelSlam::inliers_dropped(const TrackResult& t) const {
  constexpr int64_t kWarmUp = 10;  // tracked frames before the average is trusted
  return !t.lost && options_.lost_inlier_drop > 0 && inlier_samples_ >= kWarmUp &&
         t.inlier_fraction < options_.lost_inlier_drop * inlier_average_;
}

Status SurfelSlam::relocalise(const Frame& frame, const Preprocessor& pre, SlamFrameResult* result, SE3* T_world_cur) {
  constexpr int kMaxCandidates = 16;
  KeyframeMatch matches[kMaxCandidates];
  ferns_.encode(frame.depth.view(), frame.color.view(), &code_);
  const int n = ferns_.best_matches(code_, options_.ferns.match_threshold, matches,
                                    std::min(options_.relocalisation_candidates, kMaxCandidates));
  for (int i = 0; i < n; ++i) {
    const SE3 T_kf = ferns_.pose(matches[i].keyframe);
    EF_RETURN_IF_ERROR(predictor_.predict(pool_, T_kf, predicted_frame_, predicted_min_confidence_));
    prediction_stale_ = true;
    TrackResult trial;
    EF_RETURN_IF_ERROR(tracker_.track(predictor_.pyramid_view(), pyramid_view(pre), SE3(), &trial));
    if (trial.lost || inliers_dropped(trial)) continue;
    result->track = trial;
    result->keyframe = matches[i].keyframe;
    *T_world_cur = T_kf * trial.T_ref_cur;
    return Status::success();
  }
  return Status::success();
}

SurfelCloudView surfel_cloud_view(const SurfelPool& pool) {
  SurfelCloudView v;
  v.count = static_cast<std::size_t>(pool.size());
  v.x = pool.x();
  v.y = pool.y();
  v.z = pool.z();
  v.nx = pool.nx();
  v.ny = pool.ny();
  v.nz = pool.nz();
  // Packed R | G << 8 | B << 16 in a little-endian word (x86-64 and AArch64 Linux): bytes R, G, B.
  const auto* bytes = reinterpret_cast<const uint8_t*>(pool.color());
  v.red = {bytes + 0, sizeof(uint32_t)};
  v.green = {bytes + 1, sizeof(uint32_t)};
  v.blue = {bytes + 2, sizeof(uint32_t)};
  v.radius = pool.radius();
  v.confidence = pool.confidence();
  return v;
}

}  // namespace ef::slam
