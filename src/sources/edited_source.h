// A recording with frames cut out or blank frames put in: the faults a mapper must survive, made
// from real recordings (issue 30's kidnap and covered-lens tests). Any recorded scheme takes the
// query keys
//   cut=A-B    frames A..B of the recording (0-based, inclusive) are not delivered: the camera
//              "jumps" from frame A-1 to frame B+1. Timestamps are kept (time passed while it moved).
//   blank=N+K  K frames of zero depth and black colour are delivered before frame N of the
//              recording (N >= 1): a covered lens. They are spaced 1 / nominal_fps after frame N-1,
//              carry no reference pose, and every later frame's timestamp moves K / nominal_fps later
//              (the lens was covered for that long), so reference poses still match by timestamp.
// Delivered frames are numbered afresh (Frame::index); names are the recording's, "blank-NNNN" for the
// inserted ones. A live camera does not take these keys (an error says so).
//
// Memory: a blank frame is written into the caller's buffers (no allocation when they have the
// size). Threads: as the wrapped source.
#pragma once

#include <cstdint>
#include <memory>

#include "io/frame_source.h"

namespace ef {

struct FrameEdits {
  int64_t cut_first = -1, cut_last = -1;  // frames of the recording not delivered (-1: none)
  int64_t blank_before = -1;              // recording frame the blanks go before (-1: none)
  int64_t blank_count = 0;                // how many blank frames
  bool any() const { return cut_first >= 0 || blank_count > 0; }
};

// Takes the keys `cut` and `blank` out of uri.query (so the scheme's own check of its keys does not
// see them) and parses them. Errors name the key and what is malformed.
Result<FrameEdits> take_frame_edits(SourceUri& uri);

// Wraps `inner` (a recording) with `edits`. `uri_text` is the whole URI, for SourceInfo::uri.
// Errors: an edit outside the recording's frames (when its frame count is known), a live source.
Result<std::unique_ptr<FrameSource>> edit_frames(std::unique_ptr<FrameSource> inner, const FrameEdits& edits,
                                                 const std::string& uri_text);

}  // namespace ef
