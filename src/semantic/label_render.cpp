#include "semantic/label_render.h"

#include <string>

#include "semantic/label_store.h"

namespace ef::semantic {

namespace {

// True when the store has never been updated: all 14 costs zero (uniform).
bool uniform(const uint8_t* costs) {
  uint8_t any = 0;
  for (int c = 0; c < kLabelClasses; ++c) any |= costs[c];
  return any == 0;
}

}  // namespace

Result<LabelRenderCounts> render_labels(const slam::ModelPredictor& predictor, const slam::SurfelPool& pool,
                                        ImageView<const uint8_t> fallback, ImageView<uint8_t> out,
                                        ImageView<const float> depth, const DepthGate& gate) {
  const Intrinsics& k = predictor.intrinsics();
  const auto size_text = [](int w, int h) { return std::to_string(w) + "x" + std::to_string(h); };
  if (out.width != k.width || out.height != k.height)
    return error(ErrorCode::kInvalidArgument, "render_labels: output image is " + size_text(out.width, out.height) +
                                                  ", the prediction's working size is " + size_text(k.width, k.height));
  if (!fallback.empty() && (fallback.width != k.width || fallback.height != k.height))
    return error(ErrorCode::kInvalidArgument, "render_labels: fallback image is " +
                                                  size_text(fallback.width, fallback.height) +
                                                  ", the prediction's working size is " + size_text(k.width, k.height));
  if (!depth.empty() && (depth.width != k.width || depth.height != k.height))
    return error(ErrorCode::kInvalidArgument, "render_labels: depth image is " + size_text(depth.width, depth.height) +
                                                  ", the prediction's working size is " + size_text(k.width, k.height));
  const ImageView<const float> predicted_depth = predictor.depth();
  const slam::IndexMap& index = predictor.index_map();
  const ImageView<const int32_t> winner = predictor.surfel_ids();
  const int s = index.scale;
  const bool have_index = index.id.width() == k.width * s && index.id.height() == k.height * s;
  const int64_t n = pool.size();
  const uint8_t* labels = pool.labels();

  LabelRenderCounts counts;
  for (int v = 0; v < k.height; ++v) {
    uint8_t* out_row = out.row(v);
    const uint8_t* fb_row = fallback.empty() ? nullptr : fallback.row(v);
    const int32_t* win_row = winner.row(v);
    const float* zm_row = depth.empty() ? nullptr : depth.row(v);
    for (int u = 0; u < k.width; ++u) {
      const float zm = zm_row != nullptr ? zm_row[u] : 0.0f;
      const bool gated = zm > 0.0f;
      int64_t id = -1;
      bool from_index = false;
      if (have_index) {
        float best = 0;
        for (int dy = 0; dy < s; ++dy) {
          const int32_t* ids = index.id.view().row(v * s + dy) + u * s;
          const float* z = index.depth.view().row(v * s + dy) + u * s;
          for (int dx = 0; dx < s; ++dx) {
            if (ids[dx] >= 0 && (id < 0 || z[dx] < best) && (!gated || gate.accepts(z[dx], zm))) {
              id = ids[dx];
              best = z[dx];
            }
          }
        }
        from_index = id >= 0;
      }
      if (id < 0 && win_row[u] >= 0 && (!gated || gate.accepts(predicted_depth(u, v), zm))) id = win_row[u];
      if (id >= n)
        return error(ErrorCode::kInvalidArgument, "render_labels: pixel (" + std::to_string(u) + ", " +
                                                      std::to_string(v) + ") shows surfel " + std::to_string(id) +
                                                      " but the pool holds " + std::to_string(n) +
                                                      " (the pool changed after the prediction)");
      const uint8_t* costs = id >= 0 ? labels + id * slam::SurfelPool::kLabelBytesPerSurfel : nullptr;
      if (costs != nullptr && !uniform(costs)) {
        out_row[u] = static_cast<uint8_t>(label_argmax(costs));
        ++(from_index ? counts.from_index_map : counts.from_splat);
      } else {
        out_row[u] = fb_row != nullptr ? fb_row[u] : 0;
        ++counts.from_fallback;
      }
    }
  }
  return counts;
}

}  // namespace ef::semantic
