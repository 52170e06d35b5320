// The SLAM that fuzz_snapshot restores checkpoints into and that the corpus tool writes its seed
// checkpoints from: one definition, so the seeds fit the target (working size, fern count) and a
// mutation, not a mismatch of set-up, decides what restore_checkpoint() says.
#pragma once

#include "core/intrinsics.h"
#include "slam/surfel_slam.h"
#include "synth/synthetic_source.h"

namespace ef::fuzz {

// 32x32 pixels (the smallest working size `run` accepts): the synthetic camera scaled down.
inline Intrinsics checkpoint_working_intrinsics() { return synthetic_default_intrinsics().scaled_to(32, 32); }

// Small enough to create once per input in well under a millisecond: 512 surfels, 16 keyframes,
// 64 frames of pose history (the fern count stays the default, which a checkpoint must match).
inline slam::SurfelSlamOptions checkpoint_slam_options() {
  slam::SurfelSlamOptions o;
  o.pool.capacity = 512;
  o.ferns.capacity = 16;
  o.pose_history = 64;
  return o;
}

}  // namespace ef::fuzz
