#include "io/frame_resample.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace ef {

namespace {

constexpr float kEdgeDepthGapM = 0.05f;  // metres: block pixels farther than this from the nearest are dropped

// Source pixel index nearest to the centre of destination pixel `d` (centre maps as (d+0.5)*s-0.5).
inline int nearest_source(int d, float scale, int src_size) {
  const int s = static_cast<int>(std::floor((static_cast<float>(d) + 0.5f) * scale));
  return std::min(std::max(s, 0), src_size - 1);
}

void resample_depth(const Image<float>& src, Image<float>& dst) {
  const int sw = src.width(), sh = src.height(), dw = dst.width(), dh = dst.height();
  const bool integer_factor = sw % dw == 0 && sh % dh == 0 && sw / dw == sh / dh;
  if (integer_factor) {
    const int f = sw / dw;
    for (int y = 0; y < dh; ++y) {
      for (int x = 0; x < dw; ++x) {
        float nearest = 0;
        for (int j = 0; j < f; ++j)
          for (int i = 0; i < f; ++i) {
            const float z = src(x * f + i, y * f + j);
            if (z > 0 && (nearest == 0 || z < nearest)) nearest = z;
          }
        float sum = 0;
        int n = 0;
        if (nearest > 0) {
          for (int j = 0; j < f; ++j)
            for (int i = 0; i < f; ++i) {
              const float z = src(x * f + i, y * f + j);
              if (z > 0 && z - nearest < kEdgeDepthGapM) { sum += z; ++n; }
            }
        }
        dst(x, y) = n > 0 ? sum / static_cast<float>(n) : 0.0f;
      }
    }
    return;
  }
  const float sx = static_cast<float>(sw) / static_cast<float>(dw);
  const float sy = static_cast<float>(sh) / static_cast<float>(dh);
  for (int y = 0; y < dh; ++y) {
    const int ys = nearest_source(y, sy, sh);
    for (int x = 0; x < dw; ++x) dst(x, y) = src(nearest_source(x, sx, sw), ys);
  }
}

void resample_labels(const Image<uint8_t>& src, Image<uint8_t>& dst) {
  const int sw = src.width(), sh = src.height(), dw = dst.width(), dh = dst.height();
  const float sx = static_cast<float>(sw) / static_cast<float>(dw);
  const float sy = static_cast<float>(sh) / static_cast<float>(dh);
  for (int y = 0; y < dh; ++y) {
    const int ys = nearest_source(y, sy, sh);
    for (int x = 0; x < dw; ++x) dst(x, y) = src(nearest_source(x, sx, sw), ys);
  }
}

}  // namespace

void resample_frame(const Frame& src, Frame& out) {
  if (!src.color.empty() && !out.color.empty()) {
    const cv::Mat in(src.color.height(), src.color.width(), CV_8UC3, const_cast<Rgb8*>(src.color.data()));
    cv::Mat dst(out.color.height(), out.color.width(), CV_8UC3, out.color.data());
    if (in.size() == dst.size()) in.copyTo(dst);
    else cv::resize(in, dst, dst.size(), 0, 0, cv::INTER_AREA);
  }
  if (!src.depth.empty()) resample_depth(src.depth, out.depth);
  if (src.has_labels && !src.labels.empty() && !out.labels.empty()) resample_labels(src.labels, out.labels);
  out.has_labels = src.has_labels && !out.labels.empty();
  copy_frame_metadata(src, out);
}

}  // namespace ef
