#include "io/area_resampler.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace ef {

namespace {
constexpr int kMaxSide = 16384;
}  // namespace

std::size_t AreaResampler::axis_taps(int src, int dst) {
  // An output interval of length s = src / dst touches at most ceil(s) + 1 source pixels.
  if (dst >= src) return std::size_t(dst);
  return std::size_t(dst) * std::size_t((src + dst - 1) / dst + 1);
}

AreaResampler::Axis AreaResampler::make_axis(int src, int dst) {
  Axis a;
  a.first.reserve(std::size_t(dst) + 1);
  a.taps.reserve(axis_taps(src, dst));
  const double s = double(src) / double(dst);  // source pixels per output pixel
  for (int o = 0; o < dst; ++o) {
    a.first.push_back(int32_t(a.taps.size()));
    if (s <= 1.0) {  // enlarging: the nearest source pixel (pixel centres as Intrinsics::scaled_to)
      const int i = std::min(src - 1, int(std::floor((o + 0.5) * s)));
      a.taps.push_back({i, 1.0f});
      continue;
    }
    const double lo = o * s, hi = (o + 1) * s;
    for (int i = int(std::floor(lo)); i < src && i < hi; ++i) {
      const double overlap = std::min(hi, double(i + 1)) - std::max(lo, double(i));
      if (overlap > 1e-9) a.taps.push_back({i, float(overlap / s)});
    }
  }
  a.first.push_back(int32_t(a.taps.size()));
  return a;
}

Result<AreaResampler> AreaResampler::create(int src_w, int src_h, int dst_w, int dst_h) {
  for (int v : {src_w, src_h, dst_w, dst_h})
    if (v < 1 || v > kMaxSide)
      return error(ErrorCode::kInvalidArgument, "area resampler: sizes " + std::to_string(src_w) + "x" +
                                                    std::to_string(src_h) + " -> " + std::to_string(dst_w) + "x" +
                                                    std::to_string(dst_h) + " outside 1.." + std::to_string(kMaxSide));
  AreaResampler r;
  r.src_w_ = src_w;
  r.src_h_ = src_h;
  r.dst_w_ = dst_w;
  r.dst_h_ = dst_h;
  r.x_ = make_axis(src_w, dst_w);
  r.y_ = make_axis(src_h, dst_h);
  // Capacities as bytes_for() counts them (the memory plan asks bytes_for).
  r.x_.taps.reserve(axis_taps(src_w, dst_w));
  r.y_.taps.reserve(axis_taps(src_h, dst_h));
  r.row_.assign(std::size_t(src_w) * 3, 0.0f);
  return r;
}

std::size_t AreaResampler::bytes_for(int src_w, int src_h, int dst_w, int dst_h) {
  return (std::size_t(dst_w) + 1 + std::size_t(dst_h) + 1) * sizeof(int32_t) +
         (axis_taps(src_w, dst_w) + axis_taps(src_h, dst_h)) * sizeof(Tap) + std::size_t(src_w) * 3 * sizeof(float);
}

std::size_t AreaResampler::bytes() const {
  return (x_.first.capacity() + y_.first.capacity()) * sizeof(int32_t) +
         (x_.taps.capacity() + y_.taps.capacity()) * sizeof(Tap) + row_.capacity() * sizeof(float);
}

bool AreaResampler::run(ImageView<const Rgb8> src, ImageView<Rgb8> dst) {
  if (src.width != src_w_ || src.height != src_h_ || dst.width != dst_w_ || dst.height != dst_h_) return false;
  float* acc = row_.data();
  for (int y = 0; y < dst_h_; ++y) {
    std::fill(row_.begin(), row_.end(), 0.0f);
    for (int32_t t = y_.first[std::size_t(y)]; t < y_.first[std::size_t(y) + 1]; ++t) {
      const Tap tap = y_.taps[std::size_t(t)];
      const Rgb8* s = src.row(tap.index);
      for (int x = 0; x < src_w_; ++x) {
        acc[3 * x] += tap.weight * float(s[x].r);
        acc[3 * x + 1] += tap.weight * float(s[x].g);
        acc[3 * x + 2] += tap.weight * float(s[x].b);
      }
    }
    Rgb8* d = dst.row(y);
    for (int x = 0; x < dst_w_; ++x) {
      float r = 0, g = 0, b = 0;
      for (int32_t t = x_.first[std::size_t(x)]; t < x_.first[std::size_t(x) + 1]; ++t) {
        const Tap tap = x_.taps[std::size_t(t)];
        r += tap.weight * acc[3 * tap.index];
        g += tap.weight * acc[3 * tap.index + 1];
        b += tap.weight * acc[3 * tap.index + 2];
      }
      const auto u8 = [](float v) { return uint8_t(std::min(255.0f, std::max(0.0f, std::floor(v + 0.5f)))); };
      d[x] = Rgb8{u8(r), u8(g), u8(b)};
    }
  }
  return true;
}

}  // namespace ef
