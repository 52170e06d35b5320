#include "slam/surfel_slam.h"

#include "core/stopwatch.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include <Eigen/Geometry>

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
       "a tracked frame is lost when its inlier fraction falls below this fraction of the last fused frame's (a jumped "
       "camera tracked to a wrong pose); 0 = off"},
      {"loop_closure", "", "", &SurfelSlamOptions::loop_closure, "", opt::any(),
       "register fused frames against the inactive model (local) and old keyframes (global) and deform the map "
       "to close the loop"},
      {"pose_history", "", "", &SurfelSlamOptions::pose_history, "frames", opt::between(0, 1e7),
       "the last frames whose poses a loop closure corrects (trajectory.txt is rewritten with them at the end; older "
       "lines stay as tracked); allocated at start-up with loop_closure"},
      {"associate_active_only", "", "", &SurfelSlamOptions::associate_active_only, "", opt::any(),
       "fusion associates with the active model only (ElasticFusion): revisits after the time window make new "
       "surfels that loop closure deforms onto the old; false = with every surfel (the map absorbs small drift)"},
      {"loop_check_every", "", "", &SurfelSlamOptions::loop_check_every, "fused frames", opt::between(1, 1000),
       "how often the loop-closure check runs"},
      {"loop_min_correction_m", "", "", &SurfelSlamOptions::loop_min_correction_m, "metres", opt::between(0, 1),
       "a registration that moves the camera less (and turns it less than loop_min_correction_deg) closes nothing"},
      {"loop_min_correction_deg", "", "", &SurfelSlamOptions::loop_min_correction_deg, "degrees", opt::between(0, 90),
       "see loop_min_correction_m"},
      {"loop_max_residual_m", "", "", &SurfelSlamOptions::loop_max_residual_m, "metres", opt::between(0, 1),
       "a closure whose constraints stay further than this (RMS) from met after the optimisation is rejected"},
      {"relocalisation_candidates", "", "", &SurfelSlamOptions::relocalisation_candidates, "keyframes",
       opt::between(1, 16), "keyframes tried per lost frame, the most similar first"},
      {"loop_sample_step", "", "", &SurfelSlamOptions::loop_sample_step, "pixels", opt::between(1, 256),
       "a closure constrains the current view's surface at every this-many pixels of the working image"},
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
  EF_RETURN_IF_ERROR(graph.validate());
  if (loop_sample_step < 1 || loop_sample_step > 256)
    return error(ErrorCode::kInvalidArgument, "slam: loop_sample_step " + std::to_string(loop_sample_step) +
                                                  " is outside 1..256 pixels");
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
  std::optional<DeformationGraph> graph;
  if (options.loop_closure) {
    EF_ASSIGN_OR_RETURN(DeformationGraph g, DeformationGraph::create(options.graph.for_pool(options.pool.capacity)));
    graph.emplace(std::move(g));
  }
  EF_ASSIGN_OR_RETURN(PoseHistory history, PoseHistory::create(options.loop_closure ? options.pose_history : 0));
  SurfelSlam slam(options, working, std::move(pre), std::move(tracker), std::move(predictor), std::move(fusion),
                  std::move(pool), std::move(order), std::move(ferns), std::move(graph), std::move(history));
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
  s.inlier_reference = inlier_reference_;
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
  inlier_reference_ = s.inlier_reference;
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
    // Bounds stale only after a writer took a mutable column (slam/surfel_pool.h); a no-op otherwise.
    pool_.refresh_bounds();
    if (options_.associate_at_tracked_pose && fused_frames_ > 0) {
      const int32_t window = options_.prediction.active_window_frames;
      predictor_.render_index_map(pool_, T_world_cur,
                                  options_.associate_active_only && window > 0 ? frame_index - window : INT32_MIN);
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
      inlier_reference_ = result->track.inlier_fraction;
      ++inlier_samples_;
    }
    // A new view becomes a keyframe (ferns of the raw frame; a relocalised frame too).
    t0 = Clock::now();
    if (result->keyframe < 0) ferns_.encode(frame.depth.view(), frame.color.view(), &code_);  // else relocalise()'s
    result->new_keyframe = ferns_.add_if_novel(code_, T_world_cur, frame_index) >= 0;
    result->timings.keyframe_ms = ms_since(t0);

    if (graph_ && fused_frames_ % options_.loop_check_every == 0) {
      t0 = Clock::now();
      EF_RETURN_IF_ERROR(check_loop(pre, frame_index, result, &T_world_cur));
      T_world_last_ = T_world_cur;
      result->T_world_cam = T_world_cur;
      result->timings.loop_ms = ms_since(t0);
    }

    t0 = Clock::now();
    predicted_frame_ = frame_index;
    predicted_min_confidence_ = tracking_min_confidence();
    pool_.refresh_bounds();
    // The next frame's fusion renders its own index map at its tracked pose: this one's is drawn
    // only on demand (predictor_with_index_map(), for the labels).
    EF_RETURN_IF_ERROR(predictor_.predict(pool_, T_world_cur, frame_index, predicted_min_confidence_,
                                          options_.associate_at_tracked_pose ? IndexMapDraw::kSkip
                                                                             : IndexMapDraw::kDraw));
    prediction_stale_ = false;
    result->timings.predict_ms = ms_since(t0);
  }
  history_.push(frame_index, frame.timestamp, result->T_world_cam);
  ++frames_;
  result->timings.total_ms = ms_since(t_start);
  return Status::success();
}

Status SurfelSlam::register_inactive(const Preprocessor& pre, const SE3& T_ref, const SE3& T_world_cur,
                                     int32_t seen_before, bool* ok, SE3* T_loop) {
  *ok = false;
  EF_RETURN_IF_ERROR(predictor_.predict_inactive(pool_, T_ref, seen_before, options_.prediction.stable_confidence));
  prediction_stale_ = true;
  // Too little of the inactive model in view for the tracker's inlier tests: no registration to try.
  const double pixels = static_cast<double>(working_.width) * working_.height;
  if (static_cast<double>(predictor_.counters().valid_pixels) < options_.tracker.min_inliers_among(pixels))
    return Status::success();
  TrackResult trial;
  EF_RETURN_IF_ERROR(tracker_.track(predictor_.pyramid_view(), pyramid_view(pre), T_ref.inverse() * T_world_cur, &trial));
  if (trial.lost) return Status::success();
  // The inactive model covers only part of the view (the surface left longest ago), so the inliers
  // are judged against the pixels it covers: where it is, the frame must agree with it about as well
  // as tracked frames agree with the active model (lost_inlier_drop of the last fused frame's inlier
  // fraction). A registration that the tracker's own tests pass but this does not is a wrong
  // minimum; closing a loop on it would bend the map onto the wrong place (measured: one such closure
  // on 7-Scenes lost 310 frames).
  const double covered = static_cast<double>(std::max<int64_t>(1, predictor_.counters().valid_pixels));
  const double agreement = static_cast<double>(trial.icp_inliers) / covered;
  if (inlier_samples_ > 0 && agreement < options_.lost_inlier_drop * inlier_reference_) return Status::success();
  *ok = true;
  *T_loop = T_ref * trial.T_ref_cur;
  return Status::success();
}

Status SurfelSlam::check_loop(const Preprocessor& pre, int32_t frame_index, SlamFrameResult* result, SE3* T_world_cur) {
  const int32_t window = options_.prediction.active_window_frames;
  if (window <= 0 || frame_index <= window) return Status::success();
  const int32_t seen_before = frame_index - window;
  // Local: the inactive model where the camera is now.
  bool ok = false;
  SE3 T_loop;
  EF_RETURN_IF_ERROR(register_inactive(pre, *T_world_cur, *T_world_cur, seen_before, &ok, &T_loop));
  LoopKind kind = ok ? LoopKind::kLocal : LoopKind::kNone;
  if (!ok) {
    // Global: the keyframe most like this frame (code_: encoded for the keyframe test just before)
    // among those taken before the active window.
    KeyframeMatch match;
    if (ferns_.best_matches(code_, options_.ferns.match_threshold, &match, 1, seen_before) == 1) {
      EF_RETURN_IF_ERROR(register_inactive(pre, ferns_.pose(match.keyframe), *T_world_cur, seen_before, &ok, &T_loop));
      kind = ok ? LoopKind::kGlobal : LoopKind::kNone;
    }
  }
  if (!ok) return Status::success();
  result->loop_registered = true;
  const SE3 correction = T_loop * T_world_cur->inverse();
  const double moved_m = correction.translation().norm();
  const double turned_deg = Eigen::AngleAxisd(correction.rotation()).angle() * 180.0 / M_PI;
  if (moved_m < options_.loop_min_correction_m && turned_deg < options_.loop_min_correction_deg)
    return Status::success();  // the map already meets itself here
  result->loop_kind = kind;
  result->loop_correction_m = moved_m;
  int64_t& accepted = kind == LoopKind::kLocal ? loops_.local_accepted : loops_.global_accepted;
  int64_t& rejected = kind == LoopKind::kLocal ? loops_.local_rejected : loops_.global_rejected;
  if (moved_m > options_.tracker.lost_max_correction_m || turned_deg > options_.tracker.lost_max_correction_deg) {
    ++rejected;
    return Status::success();
  }

  // The current view's surface goes where the registration put it; the inactive surfels it
  // registered against stay (pinned). The predictor still holds the inactive model at the
  // registration's reference pose, its winner ids the surfels seen there.
  Status built = graph_->build(pool_);
  if (!built.ok()) {
    ++rejected;
    return Status::success();
  }
  const PyramidView view = pyramid_view(pre);
  const ImageView<const Eigen::Vector3f> vertex = view.level[0].vertex;
  const ImageView<const int32_t> ids = predictor_.surfel_ids();
  const int step = options_.loop_sample_step;
  for (int y = step / 2; y < vertex.height; y += step)
    for (int x = step / 2; x < vertex.width; x += step) {
      const Eigen::Vector3f& p = vertex(x, y);
      if (p.z() > 0) {
        const Eigen::Vector3d pd = p.cast<double>();
        graph_->add_constraint((*T_world_cur * pd).cast<float>(), frame_index, (T_loop * pd).cast<float>());
      }
      if (y < ids.height && x < ids.width) {
        const int32_t id = ids(x, y);
        if (id >= 0 && id < pool_.size()) {
          const SurfelPool& pool = pool_;  // const reads keep the block bounds current
          const Eigen::Vector3f v(pool.x()[id], pool.y()[id], pool.z()[id]);
          graph_->add_constraint(v, pool.last_seen()[id], v);
        }
      }
    }
  EF_RETURN_IF_ERROR(graph_->optimise(&result->deformation));
  if (result->deformation.rms_after_m > options_.loop_max_residual_m) {
    ++rejected;
    return Status::success();
  }
  graph_->apply(pool_);
  pool_.refresh_bounds();  // every surfel may have moved
  *T_world_cur = graph_->apply_pose(*T_world_cur, frame_index);
  for (int32_t k = 0; k < ferns_.size(); ++k) ferns_.set_pose(k, graph_->apply_pose(ferns_.pose(k), ferns_.frame(k)));
  history_.deform(*graph_);
  last_motion_ = SE3();
  result->loop_accepted = true;
  ++accepted;
  return Status::success();
}

const char* loop_kind_name(LoopKind kind) {
  switch (kind) {
    case LoopKind::kLocal: return "local";
    case LoopKind::kGlobal: return "global";
    case LoopKind::kNone: break;
  }
  return "none";
}

bool SurfelSlam::inliers_dropped(const TrackResult& t) const {
  constexpr int64_t kWarmUp = 10;         // tracked frames before the test applies
  constexpr double kDecayPerLost = 0.95;  // the reference relaxes while lost (see the option)
  if (t.lost || options_.lost_inlier_drop <= 0 || inlier_samples_ < kWarmUp) return false;
  const double reference = inlier_reference_ * std::pow(kDecayPerLost, static_cast<double>(lost_run_));
  return t.inlier_fraction < options_.lost_inlier_drop * reference;
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
