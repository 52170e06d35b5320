#include "sources/edited_source.h"

#include <algorithm>
#include <cstdio>
#include <string_view>

#include "io/text_parse.h"

namespace ef {

namespace {

constexpr int64_t kMaxFrames = int64_t{1} << 40;

// "A<sep>B" with both integers in [0, kMaxFrames].
bool parse_pair(const std::string& text, char sep, int64_t& a, int64_t& b) {
  const std::size_t at = text.find(sep);
  if (at == std::string::npos) return false;
  return text::parse_int(std::string_view(text).substr(0, at), 0, kMaxFrames, a) &&
         text::parse_int(std::string_view(text).substr(at + 1), 0, kMaxFrames, b);
}

class EditedSource final : public FrameSource {
 public:
  EditedSource(std::unique_ptr<FrameSource> inner, const FrameEdits& edits, const std::string& uri_text)
      : inner_(std::move(inner)), edits_(edits), info_(inner_->info()) {
    info_.uri = uri_text;
    dt_ = info_.nominal_fps > 0 ? 1.0 / info_.nominal_fps : 1.0 / 30.0;
    if (info_.frame_count >= 0) {
      int64_t n = info_.frame_count;
      if (edits_.cut_first >= 0) n -= std::min(edits_.cut_last, info_.frame_count - 1) - edits_.cut_first + 1;
      if (edits_.blank_count > 0) n += edits_.blank_count;
      info_.frame_count = n;
    }
  }

  const SourceInfo& info() const override { return info_; }

  Result<bool> next(Frame& out) override {
    if (position_ == edits_.blank_before && blanks_done_ < edits_.blank_count) {
      write_blank(out);
      return true;
    }
    if (position_ == edits_.cut_first) {
      const int64_t n = edits_.cut_last - edits_.cut_first + 1;
      EF_ASSIGN_OR_RETURN(const int64_t skipped, inner_->skip(n, out));
      position_ += skipped;
      if (skipped < n) return false;
      // The blanks may go right after the cut.
      if (position_ == edits_.blank_before && blanks_done_ < edits_.blank_count) {
        write_blank(out);
        return true;
      }
    }
    EF_ASSIGN_OR_RETURN(const bool got, inner_->next(out));
    if (!got) return false;
    ++position_;
    if (edits_.blank_count > 0 && position_ > edits_.blank_before)
      out.timestamp += static_cast<double>(edits_.blank_count) * dt_;
    last_timestamp_ = out.timestamp;
    out.index = delivered_++;
    return true;
  }

 private:
  void write_blank(Frame& out) {
    const int w = info_.intrinsics.width, h = info_.intrinsics.height;
    if (out.depth.width() != w || out.depth.height() != h) out.depth.allocate(w, h);
    if (out.color.width() != w || out.color.height() != h) out.color.allocate(w, h);
    out.depth.fill(0.0f);
    out.color.fill(Rgb8{0, 0, 0});
    out.has_labels = false;
    out.has_pose = false;
    ++blanks_done_;
    out.timestamp = last_timestamp_ + dt_;
    last_timestamp_ = out.timestamp;
    out.index = delivered_++;
    char name[32];
    std::snprintf(name, sizeof name, "blank-%04lld", static_cast<long long>(blanks_done_ - 1));
    out.name.assign(name);
  }

  std::unique_ptr<FrameSource> inner_;
  FrameEdits edits_;
  SourceInfo info_;
  double dt_ = 1.0 / 30.0;          // seconds between frames
  int64_t position_ = 0;            // recording frames read or cut so far
  int64_t blanks_done_ = 0;
  int64_t delivered_ = 0;
  double last_timestamp_ = 0;       // of the last delivered frame, seconds
};

}  // namespace

Result<FrameEdits> take_frame_edits(SourceUri& uri) {
  FrameEdits e;
  auto cut = uri.query.find("cut");
  if (cut != uri.query.end()) {
    if (!parse_pair(cut->second, '-', e.cut_first, e.cut_last) || e.cut_last < e.cut_first)
      return error(ErrorCode::kInvalidArgument, "source query cut='" + cut->second +
                                                    "': expected A-B, the first and last frame (0-based) to leave out, A <= B");
    uri.query.erase(cut);
  }
  auto blank = uri.query.find("blank");
  if (blank != uri.query.end()) {
    if (!parse_pair(blank->second, '+', e.blank_before, e.blank_count) || e.blank_before < 1 || e.blank_count < 1)
      return error(ErrorCode::kInvalidArgument,
                   "source query blank='" + blank->second +
                       "': expected N+K, K >= 1 blank frames put in before frame N >= 1 of the recording");
    uri.query.erase(blank);
  }
  if (e.cut_first >= 0 && e.blank_count > 0 && e.blank_before > e.cut_first && e.blank_before <= e.cut_last)
    return error(ErrorCode::kInvalidArgument, "source query: blank=" + std::to_string(e.blank_before) + "+" +
                                                  std::to_string(e.blank_count) + " goes before a frame that cut=" +
                                                  std::to_string(e.cut_first) + "-" + std::to_string(e.cut_last) +
                                                  " leaves out");
  return e;
}

Result<std::unique_ptr<FrameSource>> edit_frames(std::unique_ptr<FrameSource> inner, const FrameEdits& edits,
                                                 const std::string& uri_text) {
  const SourceInfo& info = inner->info();
  if (info.live)
    return error(ErrorCode::kInvalidArgument,
                 "source '" + uri_text + "': cut= and blank= edit recordings; a live camera does not take them");
  const int64_t n = info.frame_count;
  if (n >= 0 && edits.cut_first >= n)
    return error(ErrorCode::kInvalidArgument, "source '" + uri_text + "': cut=" + std::to_string(edits.cut_first) +
                                                  "-" + std::to_string(edits.cut_last) + " starts after the last of its " +
                                                  std::to_string(n) + " frames");
  if (n >= 0 && edits.blank_count > 0 && edits.blank_before >= n)
    return error(ErrorCode::kInvalidArgument, "source '" + uri_text + "': blank=" +
                                                  std::to_string(edits.blank_before) + "+" +
                                                  std::to_string(edits.blank_count) + " goes after the last of its " +
                                                  std::to_string(n) + " frames");
  return std::unique_ptr<FrameSource>(new EditedSource(std::move(inner), edits, uri_text));
}

}  // namespace ef
