#include "slam/keyframe_ferns.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace ef::slam {

namespace {

// splitmix64: a fixed, portable sequence (the standard library's distributions are not).
struct SplitMix {
  uint64_t state;
  uint64_t next() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1).
  double unit() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }
};

}  // namespace

const opt::Table<KeyframeFernOptions>& KeyframeFernOptions::table() {
  static const opt::Table<KeyframeFernOptions> t = {
      {"keyframe_capacity", "", "", &KeyframeFernOptions::capacity, "keyframes", opt::between(1, 1e6),
       "keyframes the relocaliser's fern database holds, allocated at start-up (a full one takes no new views)"},
      {"fern_count", "", "", &KeyframeFernOptions::ferns, "ferns", opt::between(1, 4096),
       "randomised ferns per keyframe encoding (ElasticFusion 500)"},
      {"fern_novelty", "", "", &KeyframeFernOptions::novelty_threshold, "fraction", opt::between(0, 1),
       "a tracked frame becomes a keyframe when it differs from every keyframe in more than this fraction of "
       "ferns (ElasticFusion 0.3095)"},
      {"fern_match", "", "", &KeyframeFernOptions::match_threshold, "fraction", opt::between(0, 1),
       "relocalisation tries keyframes that differ from the lost frame in at most this fraction of ferns"},
  };
  return t;
}

Status KeyframeFernOptions::validate() const {
  EF_RETURN_IF_ERROR(opt::check_table(*this, table(), "keyframe ferns"));
  if (encode_width < 1 || encode_height < 1 || encode_width > 4096 || encode_height > 4096)
    return error(ErrorCode::kInvalidArgument, "keyframe ferns: encoded image " + std::to_string(encode_width) + "x" +
                                                  std::to_string(encode_height) + " is outside 1..4096 pixels");
  if (!(depth_min_m > 0 && depth_max_m > depth_min_m))
    return error(ErrorCode::kInvalidArgument, "keyframe ferns: depth thresholds need 0 < depth_min_m < depth_max_m (" +
                                                  std::to_string(depth_min_m) + ", " + std::to_string(depth_max_m) + ")");
  return Status::success();
}

std::string KeyframeFernOptions::describe() const {
  std::ostringstream s;
  s << "ferns: " << ferns << "  # per encoding\n"
    << "encode: " << encode_width << "x" << encode_height << "  # pixels of the encoded image\n"
    << "capacity: " << capacity << "  # keyframes\n"
    << "novelty_threshold: " << novelty_threshold << "  # fraction of ferns differing\n"
    << "match_threshold: " << match_threshold << "  # fraction of ferns differing\n"
    << "depth thresholds: " << depth_min_m << ".." << depth_max_m << "  # metres\n";
  return s.str();
}

std::size_t KeyframeFerns::bytes_for(const KeyframeFernOptions& o) {
  const std::size_t n = static_cast<std::size_t>(std::max(o.capacity, 0));
  return n * (static_cast<std::size_t>(std::max(o.ferns, 0)) + SE3::kWords * sizeof(double) + sizeof(int32_t)) +
         static_cast<std::size_t>(std::max(o.ferns, 0)) * sizeof(Fern);
}

Result<KeyframeFerns> KeyframeFerns::create(int width, int height, const KeyframeFernOptions& options) {
  EF_RETURN_IF_ERROR(options.validate());
  if (width < 1 || height < 1)
    return error(ErrorCode::kInvalidArgument, "keyframe ferns: frame size " + std::to_string(width) + "x" +
                                                  std::to_string(height) + " is empty");
  KeyframeFerns f;
  f.options_ = options;
  f.width_ = width;
  f.height_ = height;
  // A block of the working image per encoded pixel; an encoded image larger than the frame reads
  // single pixels.
  const int ew = std::min(options.encode_width, width), eh = std::min(options.encode_height, height);
  f.ferns_.reset(new Fern[options.ferns]);
  SplitMix rng{options.seed};
  for (int i = 0; i < options.ferns; ++i) {
    const int u = std::min(ew - 1, static_cast<int>(rng.unit() * ew));
    const int v = std::min(eh - 1, static_cast<int>(rng.unit() * eh));
    Fern& fern = f.ferns_[i];
    fern.x0 = u * width / ew;
    fern.x1 = std::max(fern.x0 + 1, (u + 1) * width / ew);
    fern.y0 = v * height / eh;
    fern.y1 = std::max(fern.y0 + 1, (v + 1) * height / eh);
    fern.r = static_cast<float>(rng.unit() * 255.0);
    fern.g = static_cast<float>(rng.unit() * 255.0);
    fern.b = static_cast<float>(rng.unit() * 255.0);
    fern.depth_m = static_cast<float>(options.depth_min_m + rng.unit() * (options.depth_max_m - options.depth_min_m));
  }
  const std::size_t cap = static_cast<std::size_t>(options.capacity);
  f.codes_.reset(new uint8_t[cap * static_cast<std::size_t>(options.ferns)]());
  f.poses_.reset(new double[cap * SE3::kWords]());
  f.frames_.reset(new int32_t[cap]());
  return f;
}

FernCode KeyframeFerns::make_code() const {
  FernCode c;
  c.code.assign(static_cast<std::size_t>(options_.ferns), 0);
  return c;
}

void KeyframeFerns::encode(ImageView<const float> depth, ImageView<const Rgb8> color, FernCode* out) const {
  const bool has_color = color.data != nullptr && color.width == width_ && color.height == height_;
  for (int i = 0; i < options_.ferns; ++i) {
    const Fern& f = ferns_[i];
    float d_sum = 0, r_sum = 0, g_sum = 0, b_sum = 0;
    int d_n = 0, n = 0;
    for (int y = f.y0; y < f.y1; ++y) {
      const float* drow = depth.row(y);
      for (int x = f.x0; x < f.x1; ++x) {
        const float d = drow[x];
        if (d > 0) {
          d_sum += d;
          ++d_n;
        }
        if (has_color) {
          const Rgb8 c = color(x, y);
          r_sum += c.r;
          g_sum += c.g;
          b_sum += c.b;
        }
        ++n;
      }
    }
    const float inv = 1.0f / static_cast<float>(n);
    const float d = d_n > 0 ? d_sum / static_cast<float>(d_n) : 0.0f;
    uint8_t code = 0;
    if (has_color) {
      code |= r_sum * inv > f.r ? 1 : 0;
      code |= g_sum * inv > f.g ? 2 : 0;
      code |= b_sum * inv > f.b ? 4 : 0;
    }
    code |= d > f.depth_m ? 8 : 0;
    out->code[static_cast<std::size_t>(i)] = code;
  }
}

int KeyframeFerns::differing(const uint8_t* a, const uint8_t* b) const {
  // Written so the compiler vectorises it (byte compares, summed).
  int n = 0;
  for (int i = 0; i < options_.ferns; ++i) n += a[i] != b[i] ? 1 : 0;
  return n;
}

int KeyframeFerns::best_matches(const FernCode& code, float max_dissimilarity, KeyframeMatch* out, int k,
                                int32_t frame_before) const {
  if (k <= 0) return 0;
  const float inv = 1.0f / static_cast<float>(options_.ferns);
  int count = 0;
  for (int32_t id = 0; id < size_; ++id) {
    if (frames_[id] >= frame_before) continue;
    const float dis = static_cast<float>(differing(code.code.data(), this->code(id))) * inv;
    if (dis > max_dissimilarity) continue;
    // Insertion into the sorted top-k (k is a handful).
    int at = count < k ? count : k;
    if (at == k && dis >= out[k - 1].dissimilarity) continue;
    while (at > 0 && out[at - 1].dissimilarity > dis) {
      if (at < k) out[at] = out[at - 1];
      --at;
    }
    out[at] = KeyframeMatch{id, dis};
    if (count < k) ++count;
  }
  return count;
}

float KeyframeFerns::nearest_dissimilarity(const FernCode& code) const {
  int best = options_.ferns;
  for (int32_t id = 0; id < size_ && best > 0; ++id) best = std::min(best, differing(code.code.data(), this->code(id)));
  return static_cast<float>(best) / static_cast<float>(options_.ferns);
}

int32_t KeyframeFerns::add_if_novel(const FernCode& code, const SE3& T_world_cam, int32_t frame) {
  if (nearest_dissimilarity(code) <= options_.novelty_threshold) return -1;
  if (size_ >= options_.capacity) {
    ++refused_;
    return -1;
  }
  const int32_t id = size_++;
  std::copy(code.code.begin(), code.code.end(), codes_.get() + static_cast<std::size_t>(id) * options_.ferns);
  set_pose(id, T_world_cam);
  frames_[id] = frame;
  return id;
}

SE3 KeyframeFerns::pose(int32_t id) const {
  return SE3::from_words(poses_.get() + static_cast<std::size_t>(id) * SE3::kWords);
}

void KeyframeFerns::set_pose(int32_t id, const SE3& T) { T.to_words(poses_.get() + static_cast<std::size_t>(id) * SE3::kWords); }

Status KeyframeFerns::restore(int32_t count, const uint8_t* codes, const double* pose_words, const int32_t* frames,
                              uint64_t refused) {
  if (count < 0 || count > options_.capacity)
    return error(ErrorCode::kInvalidArgument, "keyframe ferns: a checkpoint of " + std::to_string(count) +
                                                  " keyframes does not fit a database of " +
                                                  std::to_string(options_.capacity) +
                                                  " (mapping.keyframe_capacity must be at least the checkpoint's)");
  std::copy(codes, codes + static_cast<std::size_t>(count) * options_.ferns, codes_.get());
  for (int32_t i = 0; i < count; ++i) {
    if (!SE3::words_are_pose(pose_words + static_cast<std::size_t>(i) * SE3::kWords))
      return error(ErrorCode::kCorruptData, "keyframe ferns: keyframe " + std::to_string(i) +
                                                "'s pose is not a rigid transform");
  }
  std::copy(pose_words, pose_words + static_cast<std::size_t>(count) * SE3::kWords, poses_.get());
  std::copy(frames, frames + count, frames_.get());
  size_ = count;
  refused_ = refused;
  return Status::success();
}

}  // namespace ef::slam
