// Bayesian label fusion (SemanticFusion, McCormac et al. ICRA 2017, section IV-C, equation 1): every
// N-th frame the CNN's class probabilities, upsampled to the working resolution by nearest neighbour,
// multiply into the distribution of every surfel the index map shows, which is then renormalised.
// The store and the update are in fixed-point log space (semantic/label_store.h,
// kernels/label_update.h), so the product is an addition and the renormalisation a subtraction.
//
// Memory: create() allocates the observation buffer (one 16-byte vector per CNN output pixel), the
// column table and the pair list (one per index-map cell at the largest index scale, 4); fuse()
// allocates nothing. Threads: one LabelFusion per thread.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/options.h"
#include "core/result.h"
#include "kernels/label_update.h"
#include "semantic/segmenter.h"
#include "semantic/visibility.h"
#include "slam/index_map.h"
#include "slam/surfel_pool.h"

namespace ef::semantic {

struct LabelFusionOptions {
  // Fuse the CNN's prediction every this many frames (frames, >= 1). Default 10 (the paper's office
  // sequence result, Table I).
  int update_every_n_frames = 10;
  // Working image size (pixels); the index map is `scale` times finer (1..4). Default 320x240.
  int working_width = 320, working_height = 240;
  // CNN output size (pixels, ProbabilityView width x height, 14 classes). Default 160x120.
  int cnn_width = 160, cnn_height = 120;
  // Visibility (semantic/visibility.h): with a depth image, a surfel of the index map is updated only
  // where its depth agrees with the measured depth of its working pixel; pixels without depth update
  // nothing. Default 3 cm + 3% of the depth.
  DepthGate visibility;
  // false: no visibility test; every surfel of the index map takes the CNN's label (and a caller's
  // rendering shows every index-map surfel: visible_depth()). Default true.
  bool visibility_test = true;

  // The keys `run` offers (section labels): every, visibility.
  static const opt::Table<LabelFusionOptions>& table();
  Status validate() const;
  std::string describe() const;
};

struct LabelFusionCounts {
  int64_t surfels_updated = 0;   // index-map cells holding a visible surfel, each one surfel's update
  int64_t hidden_skipped = 0;    // cells whose surfel failed the depth test (occluded or off the surface)
  int64_t no_depth_skipped = 0;  // cells of working pixels without a measured depth
};

class LabelFusion {
 public:
  static Result<LabelFusion> create(const LabelFusionOptions& options = {});

  const LabelFusionOptions& options() const { return options_; }
  // What create() allocates: 16 bytes per CNN pixel (observations), an int32 per index column at
  // the largest scale, and a pair (8 bytes) per index cell at the largest scale.
  static std::size_t bytes_for(const LabelFusionOptions& options);
  // The same, read off the buffers.
  std::size_t bytes() const {
    return observations_.size() + cnn_x_of_index_x_.size() * sizeof(int32_t) +
           pairs_.size() * sizeof(kernels::LabelUpdatePair);
  }
  // `depth` when the options ask for the visibility test, else the empty view: what fuse() and a
  // rendering of the same labels (semantic/label_render.h) take.
  ImageView<const float> visible_depth(ImageView<const float> depth) const {
    return options_.visibility_test ? depth : ImageView<const float>();
  }
  // True on the frames fuse() should run on: frame % update_every_n_frames == 0 (frame >= 0).
  bool due(int64_t frame) const { return frame % options_.update_every_n_frames == 0; }

  // One Bayesian update of every surfel `index` shows (ids as of the map's rendering) with `cnn`'s
  // probabilities. Working pixel of index cell (x, y): (x / scale, y / scale); its CNN pixel by the
  // segmenter's nearest-neighbour rule: cnn_x = floor((u + 0.5) * W' / W), likewise y.
  // depth: the frame's measured depth at the working size (metres, 0 = none) for the visibility
  // test, or empty to update every surfel the index map holds (as with options.visibility_test false).
  // Errors (kInvalidArgument, the pool untouched): index map, CNN or depth sizes that differ from the
  // options, a class count other than 14, an id outside 0..pool.size()-1.
  Result<LabelFusionCounts> fuse(const slam::IndexMap& index, const ProbabilityView& cnn, slam::SurfelPool& pool,
                                 ImageView<const float> depth = {});

  // The observation vectors of the last fuse() (16 bytes per CNN pixel, row-major); for tests.
  const uint8_t* observations() const { return observations_.data(); }

 private:
  LabelFusionOptions options_;
  std::vector<uint8_t> observations_;            // cnn_width * cnn_height * 16
  std::vector<int32_t> cnn_x_of_index_x_;        // working_width * kMaxIndexScale
  std::vector<kernels::LabelUpdatePair> pairs_;  // working size * kMaxIndexScale^2
};

}  // namespace ef::semantic
