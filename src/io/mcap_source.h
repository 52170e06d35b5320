// `mcap:FILE[?depth=TOPIC&color=TOPIC]`: a field log (io/mcap_log.h) replayed as a frame source, so
// a log goes through `run` and `convert` like any recording.
//
// Frames: one per message on the depth topic (default /camera/depth: CompressedImage "png" 16-bit
// or RawImage "16UC1"/"mono16", millimetres), in file order; the colour (default /camera/color:
// CompressedImage "jpeg"/"png" or RawImage "rgb8") with the same timestamp, black when that frame
// has none (a log with colour every n-th frame), none at all when the log has no colour topic;
// intrinsics and size from the first /camera/calibration message; the reference pose from
// /camera/reference_pose at the same timestamp, when the log has that topic. A log cut while
// written is read up to its last whole chunk (SourceInfo::warning says what was left out).
// Errors name the file, the frame and the fault (a missing topic, an image of the wrong size or
// format, a second calibration that differs).
//
// Frame.timestamp is the depth message's timestamp in seconds; Frame.name "frame-NNNNNN".
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include "io/frame_source.h"

namespace ef {

Result<std::unique_ptr<FrameSource>> open_mcap(const SourceUri& uri);
// The same over bytes in memory (tests, fuzzing); `data` must outlive the source.
Result<std::unique_ptr<FrameSource>> open_mcap_memory(const uint8_t* data, std::size_t size, const std::string& name);

}  // namespace ef
