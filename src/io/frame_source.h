// One interface for every frame source: dataset replays, .klg logs, the synthetic rooms and,
// in later issues, live cameras (platform/).
#pragma once

#include <cstdint>
#include <initializer_list>
#include <map>
#include <memory>
#include <string>

#include "core/frame.h"
#include "core/intrinsics.h"
#include "core/result.h"

namespace ef {

struct SourceInfo {
  std::string uri;            // as given by the user
  Intrinsics intrinsics;      // of the colour/depth images this source delivers (registered RGB-D)
  int64_t frame_count = -1;   // frames available, -1 when unknown (live cameras)
  double nominal_fps = 30;    // recording rate, Hz (for --realtime replay)
  bool has_pose = false;      // frames carry a reference T_wc
  bool has_labels = false;    // frames carry a class-id image
  bool has_color = true;      // frames carry colour (a .klg may have none)
  bool live = false;          // a camera: must never be blocked by processing
  std::string warning;        // what opening recovered from (a recording cut while written), for the
                              // user; empty when nothing
  // Where the intrinsics came from, for the user ("intrinsics.txt", "the URI's fx, fy, cx, cy", ...;
  // empty: the device or the format itself). intrinsics_assumed: a default that nothing in the
  // recording or the URI gave (a .klg, a TUM folder without intrinsics.txt): `run` warns.
  std::string intrinsics_from;
  bool intrinsics_assumed = false;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;

  virtual const SourceInfo& info() const = 0;

  // Fills `out` with the next frame. Returns true when a frame was written, false at the end of
  // the stream, or an error naming the file, the frame and the fault. `out` keeps its buffers:
  // when they already have the source's size, no image is reallocated.
  virtual Result<bool> next(Frame& out) = 0;

  // Passes over the next `n` frames without delivering them (a resumed run starts after the frames
  // its checkpoint holds); returns how many there were (fewer at the end of the stream). Recordings
  // with an index skip without decoding; the default reads them into `scratch`.
  virtual Result<int64_t> skip(int64_t n, Frame& scratch) {
    for (int64_t i = 0; i < n; ++i) {
      auto got = next(scratch);
      if (!got.ok()) return got.error();
      if (!*got) return i;
    }
    return n;
  }
};

// A parsed source URI: "scheme:path?key=value&key=value".
struct SourceUri {
  std::string scheme;                         // "synthetic", "tum", "7scenes", "klg", ...
  std::string path;                           // everything between ':' and '?', may be empty
  std::map<std::string, std::string> query;   // options after '?'
};

// Parses a URI; an error names what is malformed (no scheme, empty key, duplicated key).
Result<SourceUri> parse_source_uri(const std::string& uri);

// Rejects any query key of `uri` not in `allowed` with an error naming the key and the scheme.
Status check_query_keys(const SourceUri& uri, std::initializer_list<const char*> allowed);

// open_source(), which knows every scheme, is in sources/open_source.h.

}  // namespace ef
