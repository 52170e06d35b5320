// Keyframes encoded by randomised ferns, for relocalisation and (later) global loop closure:
// Glocker, Shotton, Criminisi, Izadi, "Real-time RGB-D camera relocalization via randomized ferns
// for keyframe encoding", TVCG 2015, as ElasticFusion uses it (Whelan et al., IJRR 2016, section 6).
//
// A fern is a pixel of a small image (ElasticFusion: 80x60 from 640x480) and one threshold per
// channel R, G, B, depth: its code is the 4 bits (R > tR, G > tG, B > tB, D > tD), 0..15. A frame's
// encoding is the codes of all ferns (500 by default), one byte each. Two encodings differ by the
// fraction of ferns whose codes differ (the "block Hamming distance", 0 = same codes, 1 = none alike).
// A tracked frame becomes a keyframe when it differs from every stored keyframe by more than
// novelty_threshold (ElasticFusion's 0.3095): the database grows with new views, not with time.
//
// The small image is not built: each fern reads the mean of the block of working-resolution pixels
// it covers (4x4 at 320x240 for 80x60; invalid depth pixels left out of the depth mean, which is 0
// when the whole block is invalid). Pixel positions and thresholds come from a fixed seed, so an
// encoding means the same in every run (checkpoints keep the database).
//
// Lookup scans every keyframe (at 2000 keyframes x 500 ferns, a million byte compares: ~0.1 ms), so
// its time is bounded by the capacity; no index to keep.
//
// Memory: create() allocates the whole database (capacity x (ferns + 60 bytes of pose and frame)); nothing else
// allocates. A full database takes no new keyframes (counted in refused()); the old views stay.
// Threads: not synchronised (the mapping thread's).
#pragma once

#include <cstddef>
#include <climits>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/options.h"
#include "core/result.h"
#include "core/se3.h"

namespace ef::slam {

struct KeyframeFernOptions {
  // Ferns per encoding (ElasticFusion 500), 1..4096.
  int32_t ferns = 500;
  // The encoded image, pixels (ElasticFusion 80x60 from 640x480; here from any working resolution).
  int32_t encode_width = 80, encode_height = 60;
  // Keyframes the database holds at most (fixed at start-up), 1..1000000.
  int32_t capacity = 2000;
  // A tracked frame becomes a keyframe when its dissimilarity to every keyframe exceeds this
  // (fraction of ferns whose codes differ, 0..1). ElasticFusion 0.3095.
  float novelty_threshold = 0.3095f;
  // Relocalisation tries keyframes whose dissimilarity is at most this (0..1), the most similar
  // first. Unrelated views differ in about 0.85-0.9 of the ferns (16 codes, skewed), a revisit in
  // 0.2-0.5.
  float match_threshold = 0.6f;
  // Random depth thresholds are drawn uniformly in [depth_min_m, depth_max_m] (metres; ElasticFusion
  // 0.8..4 m).
  float depth_min_m = 0.8f, depth_max_m = 4.0f;
  uint32_t seed = 20150501;

  static const opt::Table<KeyframeFernOptions>& table();
  Status validate() const;
  std::string describe() const;
};

// One fern encoding: `ferns` codes.
struct FernCode {
  std::vector<uint8_t> code;  // sized once by KeyframeFerns::make_code()
};

struct KeyframeMatch {
  int32_t keyframe = -1;
  float dissimilarity = 1.0f;
};

class KeyframeFerns {
 public:
  // width x height: the working resolution of the frames encode() gets.
  static Result<KeyframeFerns> create(int width, int height, const KeyframeFernOptions& options = {});
  static std::size_t bytes_for(const KeyframeFernOptions& options);
  std::size_t bytes() const { return bytes_for(options_); }

  // A code buffer of the right size (allocates; make it once).
  FernCode make_code() const;
  // Encodes a frame (depth in metres, 0 = invalid; colour may be empty: its bits are 0). The images
  // must have the size create() was given. No allocation.
  void encode(ImageView<const float> depth, ImageView<const Rgb8> color, FernCode* out) const;

  // The `k` most similar keyframes with dissimilarity <= max_dissimilarity, taken before frame
  // `frame_before`, most similar first (fewer when fewer qualify); returns how many were written into
  // out[0..k). No allocation.
  int best_matches(const FernCode& code, float max_dissimilarity, KeyframeMatch* out, int k,
                   int32_t frame_before = INT32_MAX) const;
  // The dissimilarity to the most similar keyframe (1 when there is none).
  float nearest_dissimilarity(const FernCode& code) const;
  // Adds `code` as a keyframe at pose T_world_cam, frame index `frame`, when it is novel (see above)
  // and there is room; returns its id, or -1 (not novel, or full: counted in refused()).
  int32_t add_if_novel(const FernCode& code, const SE3& T_world_cam, int32_t frame);

  int32_t size() const { return size_; }
  int32_t capacity() const { return options_.capacity; }
  uint64_t refused() const { return refused_; }
  SE3 pose(int32_t id) const;
  int32_t frame(int32_t id) const { return frames_[id]; }
  // The stored codes of keyframe `id` (ferns() bytes), for checkpoints and tests.
  const uint8_t* code(int32_t id) const { return codes_.get() + static_cast<std::size_t>(id) * options_.ferns; }
  int32_t ferns() const { return options_.ferns; }
  const KeyframeFernOptions& options() const { return options_; }

  // Changes a keyframe's pose (a loop closure corrected the map it was taken in).
  void set_pose(int32_t id, const SE3& T_world_cam);
  // The poses as stored, 7 doubles per keyframe (translation xyz, unit quaternion xyzw): what a
  // checkpoint writes. frames(): the frame index of each.
  const double* pose_words() const { return poses_.get(); }
  const int32_t* frames() const { return frames_.get(); }
  // Restores the database from a checkpoint: `count` keyframes, their codes (count x ferns bytes),
  // pose words (count x SE3::kWords) and frames. Errors: count > capacity, a pose that is not rigid.
  Status restore(int32_t count, const uint8_t* codes, const double* pose_words, const int32_t* frames,
                 uint64_t refused);

 private:
  KeyframeFerns() = default;
  int differing(const uint8_t* a, const uint8_t* b) const;

  struct Fern {
    int32_t x0, y0, x1, y1;   // the block of working pixels it averages, [x0, x1) x [y0, y1)
    float r, g, b;            // colour thresholds, 0..255
    float depth_m;            // depth threshold, metres
  };
  KeyframeFernOptions options_;
  int width_ = 0, height_ = 0;
  std::unique_ptr<Fern[]> ferns_;
  std::unique_ptr<uint8_t[]> codes_;   // capacity x ferns
  std::unique_ptr<double[]> poses_;   // capacity x 7: t xyz, q xyzw
  std::unique_ptr<int32_t[]> frames_;
  int32_t size_ = 0;
  uint64_t refused_ = 0;
};

}  // namespace ef::slam
