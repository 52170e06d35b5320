// The finished map's labels in every K-th frame of a recording (`edgefusion run --labels-final-out
// DIR`): after the run, the recording is read a second time and each frame's view of the final map
// is rendered at the pose the run estimated for it (trajectory.txt), the paper's "SemanticFusion
// after the completed trajectory" (McCormac et al. ICRA 2017, Fig. 6, the qualitative NYUv2
// results). `--labels-out` shows the map as it was when the frame arrived (what a robot knows at
// that moment); this shows what the map knows in the end, including the views from after the frame.
//
// Per frame (the run's own rules, so that the two outputs differ only in the map's state):
//   resample to the working size (io/frame_resample.h, as the front stage does);
//   the CNN's labels as the fallback (RunSemantics::segment);
//   the map seen from the frame's pose by a predictor of the whole map (no active time window: every
//   surfel that survived takes part), rendered by semantic::render_labels with the run's visibility
//   test; a frame the run lost takes the CNN's labels, as in the run;
//   written as DIR/<frame name>.png (the names --labels-out uses), for the frames whose 0-based
//   number is a multiple of labels.out_every.
// Frames are matched to trajectory lines by timestamp (written with microseconds), in order, so a
// frame the run never mapped (it stopped early, or the recording had a corrupt frame) is skipped
// and counted, never given another frame's pose.
//
// Memory: FinalLabelBuffers, allocated once at the start of the pass (a frame at the source's and the
// working size, one CNN result, a predictor and the rendered image: 10.7 MB for a 640x480 source at
// 320x240, the memory plan's "final label pass", which tests/pipeline/test_memory_plan.cpp checks against
// bytes()); nothing per frame except inside libpng. It runs after the run's outputs are written, so
// a failure here never loses them.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "core/result.h"
#include "io/frame_source.h"
#include "pipeline/run_config.h"
#include "pipeline/run_semantics.h"
#include "slam/surfel_slam.h"

namespace ef::pipeline {

// What the pass allocates at its start, sized from the run and the recording.
struct FinalLabelBuffers {
  slam::ModelPredictor predictor;  // the run's prediction options without the active time window
  Frame input;                     // a frame at the recording's size
  Frame working;                   // resampled to the run's working size
  CnnResult cnn;                   // the fallback labels (RunSemantics::allocate)
  Image<uint8_t> rendered;         // class ids at the working size

  // Errors: those of ModelPredictor::create.
  static Result<FinalLabelBuffers> create(const RunOptions& run, const SourceInfo& recording,
                                          const slam::SurfelSlam& slam, const RunSemantics& semantics);
  // Bytes of the buffers above (the predictor's by ModelPredictor::bytes()).
  std::size_t bytes() const;
  // What create() allocates: a recording frame of `source_width` x `source_height` and a working
  // frame (with labels when the recording has them), a predictor of `predictor_bytes`
  // (ModelPredictor::bytes_for), a CNN result of `cnn_result_bytes` (CnnResult::bytes_for) and the
  // rendered class ids at the working size.
  static std::size_t bytes_for(const RunOptions& run, int source_width, int source_height, bool with_labels,
                               std::size_t predictor_bytes, std::size_t cnn_result_bytes);
};

struct FinalLabelCounts {
  int64_t frames_read = 0;     // frames of the second reading
  int64_t images_written = 0;  // DIR/<name>.png files
  int64_t from_cnn_only = 0;   // images of frames the run had lost: the CNN's labels alone
  int64_t not_mapped = 0;      // due frames without a trajectory line (skipped, no image)
  bool stopped = false;        // stop() said so: the pass ended early (the images so far are whole)
};

// replay: the recording, opened again at its start (a live camera cannot be read twice: the
// caller refuses it). trajectory_path: the run's closed trajectory.txt. slam: the finished map.
// semantics: the run's (its segmenter gives the fallback). Errors name the file or the frame:
// trajectory unreadable, a source error, a write failure.
// run: the working resolution, max frames and the progress line; labels: out_every and the
// folder (final_out).
// The reading ends after the frame of the trajectory's last pose (a run stopped early mapped no more),
// or when `stop` (if given) returns true, checked before each frame.
Result<FinalLabelCounts> render_final_labels(const RunOptions& run, const LabelOptions& labels, FrameSource& replay,
                                             const std::string& trajectory_path, const slam::SurfelSlam& slam,
                                             RunSemantics& semantics, const std::function<bool()>& stop = {});

}  // namespace ef::pipeline
