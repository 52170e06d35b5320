#include "pipeline/final_labels.h"

#include <cmath>
#include <cstdio>
#include <vector>

#include "io/frame_resample.h"
#include "io/label_image.h"
#include "io/trajectory_io.h"
#include "core/progress.h"
#include "semantic/label_render.h"
#include "slam/model_prediction.h"

namespace ef::pipeline {

namespace {

// trajectory.txt writes timestamps with 6 decimals: a frame and its line agree within half a
// microsecond; 2 us leaves room for the double's own rounding and is far below any frame interval.
constexpr double kTimestampToleranceS = 2e-6;

bool same_time(double a, double b) { return std::fabs(a - b) <= kTimestampToleranceS; }

}  // namespace

Result<FinalLabelBuffers> FinalLabelBuffers::create(const RunOptions& run, const SourceInfo& recording,
                                                    const slam::SurfelSlam& slam, const RunSemantics& semantics) {
  // The whole map: the tracking prediction's active time window would hide what the run saw long ago.
  const slam::ModelPredictor& live = slam.predictor();
  slam::PredictionOptions po = live.options();
  po.active_window_frames = 0;
  auto predictor = slam::ModelPredictor::create(live.intrinsics(), live.levels(), po);
  if (!predictor.ok()) return predictor.take_error();
  FinalLabelBuffers b{std::move(*predictor), Frame{}, Frame{}, CnnResult{}, Image<uint8_t>{}};
  b.input.allocate(recording.intrinsics.width, recording.intrinsics.height, recording.has_labels);
  b.working.allocate(run.resolution.width, run.resolution.height, recording.has_labels);
  semantics.allocate(b.cnn);
  b.rendered.allocate(run.resolution.width, run.resolution.height);
  // The memory plan sizes these buffers by bytes_for(): the two must never disagree.
  const std::size_t planned = bytes_for(run, recording.intrinsics.width, recording.intrinsics.height,
                                        recording.has_labels, b.predictor.bytes(), b.cnn.bytes());
  if (b.bytes() != planned)
    return error(ErrorCode::kInternal, "final label pass: allocated " + std::to_string(b.bytes()) +
                                           " bytes, bytes_for() says " + std::to_string(planned));
  return b;
}

std::size_t FinalLabelBuffers::bytes_for(const RunOptions& run, int source_width, int source_height, bool with_labels,
                                         std::size_t predictor_bytes, std::size_t cnn_result_bytes) {
  const int w = run.resolution.width, h = run.resolution.height;
  return predictor_bytes + Frame::bytes_for(source_width, source_height, with_labels) +
         Frame::bytes_for(w, h, with_labels) + cnn_result_bytes + std::size_t(w) * std::size_t(h);
}

std::size_t FinalLabelBuffers::bytes() const {
  return predictor.bytes() + input.bytes() + working.bytes() + cnn.bytes() + rendered.size();
}

Result<FinalLabelCounts> render_final_labels(const RunOptions& run, const LabelOptions& labels, FrameSource& replay,
                                             const std::string& trajectory_path, const slam::SurfelSlam& slam,
                                             RunSemantics& semantics, const std::function<bool()>& stop) {
  auto trajectory = read_tum_trajectory(trajectory_path);  // lost frames come marked (io/trajectory_io.h)
  if (!trajectory.ok()) return trajectory.take_error();

  const SourceInfo& info = replay.info();
  auto buffers = FinalLabelBuffers::create(run, info, slam, semantics);
  if (!buffers.ok()) return buffers.take_error();
  auto& [predictor, input, working, cnn, rendered] = *buffers;

  const std::vector<TimedPose>& poses = trajectory->poses;
  const int32_t last_frame = static_cast<int32_t>(slam.frames() > 0 ? slam.frames() - 1 : 0);
  int64_t expected = info.frame_count;
  if (run.frames > 0 && (expected < 0 || run.frames < expected)) expected = run.frames;
  Progress progress("final labels", expected, run.progress);
  char line[64];
  FinalLabelCounts counts;
  std::size_t next_pose = 0;
  for (int64_t number = 0; run.frames < 0 || number < run.frames; ++number) {
    if (stop && stop()) {
      counts.stopped = true;
      break;
    }
    auto got = replay.next(input);
    if (!got.ok()) return got.take_error();
    if (!*got) break;
    // Past the last frame the run mapped (it was stopped early): nothing more to render.
    if (!poses.empty() && input.timestamp > poses.back().timestamp + kTimestampToleranceS) break;
    ++counts.frames_read;
    std::snprintf(line, sizeof line, "%lld images", static_cast<long long>(counts.images_written));
    progress.update(counts.frames_read, line);
    // Poses are in frame order: pass those of frames the run had and this reading lacks.
    const double t = input.timestamp;
    while (next_pose < poses.size() && poses[next_pose].timestamp < t - kTimestampToleranceS) ++next_pose;
    const bool has_pose = next_pose < poses.size() && same_time(poses[next_pose].timestamp, t);
    if (number % labels.out_every != 0) continue;
    if (!has_pose) {
      ++counts.not_mapped;
      continue;
    }

    resample_frame(input, working);
    EF_RETURN_IF_ERROR(semantics.segment(working, cnn));
    if (poses[next_pose].lost) {
      rendered.copy_from(cnn.labels.view());
      ++counts.from_cnn_only;
    } else {
      EF_RETURN_IF_ERROR(predictor.predict(slam.pool(), poses[next_pose].T_wc, last_frame,
                                           slam.tracking_min_confidence()));
      auto r = semantic::render_labels(predictor, slam.pool(), cnn.labels.view(), rendered.view(),
                                      semantics.visible_depth(working.depth.view()));
      if (!r.ok()) return r.take_error();
    }
    EF_RETURN_IF_ERROR(write_label_png_ids(label_image_path(labels.final_out, working), rendered.view()));
    ++counts.images_written;
  }
  progress.finish(counts.frames_read);
  return counts;
}

}  // namespace ef::pipeline
