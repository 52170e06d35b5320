// libFuzzer target for source URIs and the query values each scheme parses: the URI parser
// (io/frame_source.h), the frame edits cut=A-B and blank=N+K (sources/edited_source.h), synthetic:'s
// options (room, seed, trajectory, frames, size, noise, camera, layout, depth_bias), the cameras'
// requests (size, fps, timeout_ms, registration, format, depth_scale; platform/devices: parsed
// without touching a device), and, for the recordings (tum:, 7scenes:, klg:, mcap:), their whole
// opening through open_source() with the URI's query: size=, fx/fy/cx/cy, depth=/color= topics,
// cut and blank, and the first frames read through the edits.
// Input: the URI's text. A recording's path is replaced by a fixture this process writes at start
// (tests/fuzz/fixtures.h: two 16x12 synthetic frames in each format), so no URI reaches another file
// or device. Any crash, sanitizer report or hang is a bug; an error is the expected answer.
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>

#include "fixtures.h"
#include "fuzz_support.h"
#include "io/frame_source.h"
#include "platform/devices/camera_common.h"
#include "platform/devices/cameras.h"
#include "sources/edited_source.h"
#include "sources/open_source.h"
#include "synth/synthetic_source.h"

namespace {

// scheme -> the fixture a recording URI is pointed at.
const std::map<std::string, std::string>& fixtures() {
  static const std::map<std::string, std::string> paths = [] {
    const std::filesystem::path dir = ef::fuzz::scratch_dir();
    const ef::fuzz::Recording r = ef::fuzz::synthetic_recording(2, 16, 12);
    const std::string klg = (dir / "rec.klg").string(), mcap = (dir / "rec.mcap").string();
    ef::fuzz::write_klg(klg, r, ef::KlgWriteOptions{});
    ef::fuzz::write_mcap(mcap, r, ef::McapLogOptions{});
    ef::fuzz::write_tum((dir / "tum").string(), r);
    ef::fuzz::write_7scenes((dir / "7scenes").string(), r);
    return std::map<std::string, std::string>{
        {"klg", klg}, {"mcap", mcap}, {"tum", (dir / "tum").string()}, {"7scenes", (dir / "7scenes").string()}};
  }();
  return paths;
}

void read_some(ef::FrameSource& source) {
  ef::Frame frame;
  for (int i = 0; i < 5; ++i) {
    auto got = source.next(frame);
    if (!got.ok() || !*got) break;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::map<std::string, std::string>& recordings = fixtures();
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto parsed = ef::parse_source_uri(text);
  if (!parsed.ok()) return 0;
  ef::SourceUri uri = *parsed;
  auto edits = ef::take_frame_edits(uri);
  if (!edits.ok()) return 0;

  if (uri.scheme == "synthetic") {
    auto options = ef::synth::parse_synthetic_options(uri);
    // Rendering is not parsing: only tiny, short sequences are opened (the room is built, a frame drawn).
    if (options.ok() && options->width * options->height <= 16 * 16 && options->frames <= 4) {
      auto source = ef::open_source(text);
      if (source.ok()) read_some(**source);
    }
    return 0;
  }
  if (uri.scheme == "openni2") {
    (void)ef::camera::parse_openni2_request(uri);
    (void)ef::probe_openni2_camera(uri);
    return 0;
  }
  if (uri.scheme == "v4l2") {
    (void)ef::camera::parse_v4l2_request(uri);
    (void)ef::probe_v4l2_camera(uri);
    return 0;
  }
  const auto fixture = recordings.find(uri.scheme);
  if (fixture == recordings.end()) {
    (void)ef::open_source(text);  // an unknown scheme: the error naming it
    return 0;
  }
  // The same URI on the fixture: scheme, the fixture's path, the query as written.
  const std::size_t colon = text.find(':');
  const std::size_t query = text.find('?', colon + 1);
  const std::string on_fixture =
      uri.scheme + ":" + fixture->second + (query == std::string::npos ? std::string() : text.substr(query));
  auto source = ef::open_source(on_fixture);
  if (source.ok()) {
    (void)ef::probe_of(**source);
    read_some(**source);
  }
  return 0;
}
