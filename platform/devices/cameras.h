// Live cameras as io FrameSources: OpenNI2 (PrimeSense / Kinect-class RGB-D sensors and .oni
// recordings) and V4L2 (UVC cameras). sources/open_source.cpp maps the URI schemes onto these.
//
// openni2:[DEVICE][?size=WxH&fps=N&timeout_ms=N&registration=0|1&fx=..&fy=..&cx=..&cy=..]
//   DEVICE empty: the first device OpenNI2 finds; otherwise an OpenNI2 device URI (as listed by
//   OpenNI2, e.g. "1d27/0601@2/5", or "Dummy" for OpenNI2's software test device) or the path of a
//   .oni recording. Frames carry depth (metres, 0 = invalid, from the 1 mm or 100 um depth formats)
//   and colour (RGB888) of the same size; depth is registered to colour where the device supports
//   it (registration=0 turns that off). size: the depth (and colour) mode, default 640x480 when the
//   device has it, else the largest mode both streams share; fps default 30 when available.
//   Timestamps: the depth frame's device clock in seconds (increasing). Intrinsics from the field of
//   view the driver reports (fx = (W / 2) / tan(hfov / 2), principal point at the image centre), of
//   the colour stream when registered; a driver that reports none (the Dummy device) gets the
//   PrimeSense default fx = fy = 525 at 640x480, scaled; fx, fy, cx, cy override single values.
//   A device is live (SourceInfo::live, frame_count -1); a .oni file is not (frame_count from the
//   recording, replayed at playback speed -1, frame by frame as next() is called; a frame that does
//   not come within timeout_ms is a kIoError). Caveat: .oni replay is untested: recordings of the
//   Dummy device made with OpenNI2's Recorder open in Debian's OniFile driver (frame counts right)
//   but deliver no frames, at any speed, so the test suite has no .oni to play.
//
// v4l2:/dev/videoN[?format=rgb|z16&size=WxH&fps=N&timeout_ms=N&depth_scale=S&fx=..&fy=..&cx=..&cy=..]
//   A Video4Linux2 capture device streamed with memory-mapped buffers through libv4l2.
//   format=rgb (default): a colour camera. libv4l2 converts whatever the camera sends (YUYV, MJPEG,
//     ...) to RGB24; frames carry colour, and a depth image of the same size that is all 0 (invalid),
//     so such a source feeds segmentation but not SLAM.
//   format=z16: a depth camera exposing 16-bit depth (V4L2_PIX_FMT_Z16, e.g. the depth node of an
//     Intel RealSense through uvcvideo); depth = raw * depth_scale metres (default 0.001), 0 =
//     invalid; no colour (SourceInfo::has_color = false).
//   size default 640x480 (the driver may pick the nearest size it has; the source reports what it
//   got), fps default 30. Timestamps: the buffer's timestamp (the kernel's monotonic clock, seconds).
//   Intrinsics: V4L2 does not know them; default fx = fy = 525 at 640x480, scaled, principal point at
//   the centre; pass fx, fy, cx, cy for a calibrated camera.
//
// Errors of next() for a live camera, so that the run loop can tell them apart:
//   kNotFound    the camera is gone (unplugged, powered off, disconnected by its driver, or no frame
//                within timeout_ms, default 2000): the message contains "camera lost". The run loop
//                stops capture and writes its outputs (sources/open_source.h: is_camera_lost()).
//   kCorruptData one frame was bad (wrong size, truncated buffer, driver error flag); the next call
//                may succeed.
//   kIoError     any other failing read.
//
// Threads: open and next() from one thread (the capture thread); notify_disconnected() from any.
#pragma once

#include <memory>
#include <string>

#include "io/frame_source.h"

namespace ef {

// Text every "the camera is gone" error message contains.
inline constexpr const char* kCameraLostText = "camera lost";

// A live camera. Besides FrameSource it can be told that its device has gone.
class CameraSource : public FrameSource {
 public:
  // Marks the camera as gone: the next next() returns the kNotFound "camera lost" error (a next()
  // blocked waiting for a frame returns it when its wait ends, within timeout_ms). The OpenNI2
  // source calls it from OpenNI's device-disconnected listener; a supervisor (a hot-plug monitor,
  // a watchdog) may call it too. Thread-safe.
  virtual void notify_disconnected() = 0;
};

// Opens `openni2:` / `v4l2:` URIs (uri.scheme is not checked). Errors name the URI: kNotFound for a
// device or file that is not there, kInvalidArgument for a bad query, kUnsupported for a device
// without the needed streams or formats, or for a build without the package (message "not built").
Result<std::unique_ptr<CameraSource>> open_openni2_camera(const SourceUri& uri);
Result<std::unique_ptr<CameraSource>> open_v4l2_camera(const SourceUri& uri);

// What a camera URI will deliver, from the URI alone (no device is touched), for the memory plan:
// the frame size (size=, else the 640x480 the camera is asked for by default) and whether it is a
// live device (a .oni recording is not). Errors: those open_*_camera() gives for the same query
// (unknown keys, bad values), and its kUnsupported "not built" in a build without the package.
struct CameraProbe {
  int width = 640, height = 480;
  bool size_given = false;
  bool live = true;
};
Result<CameraProbe> probe_openni2_camera(const SourceUri& uri);
Result<CameraProbe> probe_v4l2_camera(const SourceUri& uri);

// Whether this build has each back-end (CMake found libopenni2-dev / libv4l-dev).
bool openni2_built();
bool v4l2_built();

}  // namespace ef
