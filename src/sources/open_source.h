// Opens any frame source from its URI: the one place that knows every scheme.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "io/frame_source.h"

namespace ef {

// Schemes: synthetic:[ROOM|random][?seed=N&trajectory=loop|robot|inspect&frames=N], tum:DIR, 7scenes:DIR,
// klg:FILE[?size=WxH], mcap:FILE (io/mcap_source.h), and the live cameras of platform/devices/cameras.h (which documents them):
//   openni2:[DEVICE|FILE.oni][?size=WxH&fps=N&timeout_ms=N&registration=0|1&fx=..&fy=..&cx=..&cy=..]
//       an OpenNI2 RGB-D camera (empty: the first one; "Dummy": OpenNI2's software test device) or
//       a .oni recording; depth in metres registered to colour where the device can.
//   v4l2:/dev/videoN[?format=rgb|z16&size=WxH&fps=N&timeout_ms=N&depth_scale=S&fx=..]
//       a Video4Linux2 camera: colour (rgb, depth all invalid) or 16-bit depth (z16, no colour).
// Every recording also takes cut=A-B and blank=N+K (sources/edited_source.h: frames left out, a
// covered lens).
// Unknown schemes and unknown query keys are errors that name them. A camera scheme in a build
// configured without its package is a kUnsupported error saying "not built: missing package ...".
Result<std::unique_ptr<FrameSource>> open_source(const std::string& uri);

// What a source will deliver, known before the run starts: for `edgefusion plan`, and the memory
// plan of `run`.
struct SourceProbe {
  int width = 0, height = 0;  // frame size, pixels
  bool size_assumed = false;  // a camera without size=: the 640x480 it is asked for by default
  bool live = false;          // a live camera (capture thread and ring), not a recording
  bool has_labels = false;    // frames carry label images (synthetic rooms, TUM folders with labels/)
  int64_t frame_count = -1;   // frames of a recording; -1 when unknown (live)
};

// The probe of `uri`. A recording (synthetic, tum, 7scenes, klg, a .oni file) is opened and closed
// again, so that its real frame size is known and every error open_source() would give for it is
// given here; a live camera is not touched: its URI is checked as opening it would, and its size is
// the one asked for (CameraProbe). Errors: open_source()'s.
Result<SourceProbe> probe_source(const std::string& uri);
// The probe of a source already open.
SourceProbe probe_of(const FrameSource& source);

// Whether an error from `source`'s next() means its camera is gone (unplugged, powered off,
// disconnected, or silent for the source's timeout_ms): a live source's kNotFound. The run loop then
// stops capture as if the user had pressed stop, and writes its outputs; a decode error
// (kCorruptData) of one live frame is not this, and a replayed file never gives it.
bool is_camera_lost(const SourceInfo& source, const Error& err);

// "synthetic:, synthetic:ROOM, tum:DIR, ..." for help texts.
const char* source_uri_help();

}  // namespace ef
