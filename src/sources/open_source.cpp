#include "sources/open_source.h"

#include "io/klg_format.h"
#include "io/mcap_source.h"
#include "io/sevenscenes_source.h"
#include "io/tum_source.h"
#include "sources/edited_source.h"
#include "platform/devices/cameras.h"
#include "synth/synthetic_source.h"

namespace ef {

namespace {

Result<std::unique_ptr<FrameSource>> open_scheme(const std::string& uri_text, const SourceUri& uri) {
  if (uri.scheme == "synthetic") return open_synthetic(uri);
  if (uri.scheme == "tum") return open_tum(uri);
  if (uri.scheme == "7scenes") return open_7scenes(uri);
  if (uri.scheme == "klg") return open_klg(uri);
  if (uri.scheme == "mcap") return open_mcap(uri);
  if (uri.scheme == "openni2" || uri.scheme == "v4l2") {
    auto camera = uri.scheme == "openni2" ? open_openni2_camera(uri) : open_v4l2_camera(uri);
    if (!camera.ok()) return camera.take_error();
    return std::unique_ptr<FrameSource>(std::move(camera).value());
  }
  return error(ErrorCode::kInvalidArgument, "source '" + uri_text + "': unknown scheme '" + uri.scheme +
                                                "' (expected one of: " + source_uri_help() + ")");
}

}  // namespace

Result<std::unique_ptr<FrameSource>> open_source(const std::string& uri_text) {
  EF_ASSIGN_OR_RETURN(SourceUri uri, parse_source_uri(uri_text));
  EF_ASSIGN_OR_RETURN(const FrameEdits edits, take_frame_edits(uri));
  EF_ASSIGN_OR_RETURN(std::unique_ptr<FrameSource> source, open_scheme(uri_text, uri));
  if (!edits.any()) return source;
  return edit_frames(std::move(source), edits, uri_text);
}

SourceProbe probe_of(const FrameSource& source) {
  const SourceInfo& info = source.info();
  SourceProbe p;
  p.width = info.intrinsics.width;
  p.height = info.intrinsics.height;
  p.live = info.live;
  p.has_labels = info.has_labels;
  p.frame_count = info.frame_count;
  return p;
}

Result<SourceProbe> probe_source(const std::string& uri_text) {
  EF_ASSIGN_OR_RETURN(SourceUri uri, parse_source_uri(uri_text));
  if (uri.scheme == "openni2" || uri.scheme == "v4l2") {
    EF_ASSIGN_OR_RETURN(const CameraProbe c, uri.scheme == "openni2" ? probe_openni2_camera(uri) : probe_v4l2_camera(uri));
    if (c.live) {
      SourceProbe p;
      p.width = c.width;
      p.height = c.height;
      p.size_assumed = !c.size_given;
      p.live = true;
      return p;
    }
  }
  EF_ASSIGN_OR_RETURN(std::unique_ptr<FrameSource> source, open_source(uri_text));
  return probe_of(*source);
}

bool is_camera_lost(const SourceInfo& source, const Error& err) {
  return source.live && err.code == ErrorCode::kNotFound;
}

const char* source_uri_help() {
  return "synthetic:, synthetic:ROOM, synthetic:random?seed=N (query: seed, trajectory=loop|robot|inspect, frames, "
         "size=WxH, noise=0|1, camera=ideal|kinect, layout=walls|island), tum:DIR, 7scenes:DIR, klg:FILE[?size=WxH], mcap:FILE (a field log; query: depth=TOPIC, color=TOPIC), openni2:[DEVICE|FILE.oni] "
         "(query: size=WxH, fps, timeout_ms, registration=0|1, fx, fy, cx, cy), v4l2:/dev/videoN (query: "
         "format=rgb|z16, size=WxH, fps, timeout_ms, depth_scale, fx, fy, cx, cy); every recording also takes cut=A-B "
         "(frames A..B left out) and blank=N+K (K blank frames before frame N), and tum:, 7scenes: and klg: take "
         "fx, fy, cx, cy (pixels at the recording's size; a .klg holds none: 525, 319.5, 239.5 assumed)";
}

}  // namespace ef
