// Opens any frame source from its URI: the one place that knows every scheme.
#pragma once

#include <memory>
#include <string>

#include "io/frame_source.h"

namespace ef {

// Schemes: synthetic:[ROOM|random][?seed=N&trajectory=loop|robot|inspect&frames=N], tum:DIR, 7scenes:DIR,
// klg:FILE[?size=WxH], and the live cameras of platform/devices/cameras.h (which documents them):
//   openni2:[DEVICE|FILE.oni][?size=WxH&fps=N&timeout_ms=N&registration=0|1&fx=..&fy=..&cx=..&cy=..]
//       an OpenNI2 RGB-D camera (empty: the first one; "Dummy": OpenNI2's software test device) or
//       a .oni recording; depth in metres registered to colour where the device can.
//   v4l2:/dev/videoN[?format=rgb|z16&size=WxH&fps=N&timeout_ms=N&depth_scale=S&fx=..]
//       a Video4Linux2 camera: colour (rgb, depth all invalid) or 16-bit depth (z16, no colour).
// Unknown schemes and unknown query keys are errors that name them. A camera scheme in a build
// configured without its package is a kUnsupported error saying "not built: missing package ...".
Result<std::unique_ptr<FrameSource>> open_source(const std::string& uri);

// Whether an error from `source`'s next() means its camera is gone (unplugged, powered off,
// disconnected, or silent for the source's timeout_ms): a live source's kNotFound. The run loop then
// stops capture as if the user had pressed stop, and writes its outputs; a decode error
// (kCorruptData) of one live frame is not this, and a replayed file never gives it.
bool is_camera_lost(const SourceInfo& source, const Error& err);

// "synthetic:, synthetic:ROOM, tum:DIR, ..." for help texts.
const char* source_uri_help();

}  // namespace ef
