// Recordings made with our own writers from a few tiny synthetic frames: the fixtures fuzz_uri opens
// its URIs on, and the seeds the corpus tool writes (tests/fuzz/corpus_tool). Errors abort: these
// are set-up, never what is under test.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "core/frame.h"
#include "io/image_codec.h"
#include "io/klg_format.h"
#include "io/mcap_log.h"
#include "io/tum_writer.h"
#include "sources/open_source.h"

namespace ef::fuzz {

inline void check(const Status& s, const char* what) {
  if (s.ok()) return;
  std::fprintf(stderr, "fuzz fixture: %s: %s\n", what, to_string(s.error()).c_str());
  std::abort();
}

struct Recording {
  std::vector<Frame> frames;
  Intrinsics intrinsics;
};

// `frames` frames of a synthetic room at width x height (poses and labels included).
inline Recording synthetic_recording(int frames, int width, int height, const std::string& extra_query = "") {
  const std::string uri = "synthetic:?frames=" + std::to_string(frames) + "&size=" + std::to_string(width) + "x" +
                          std::to_string(height) + extra_query;
  auto source = open_source(uri);
  if (!source.ok()) check(source.error(), uri.c_str());
  Recording r;
  r.intrinsics = (*source)->info().intrinsics;
  Frame f;
  for (;;) {
    auto got = (*source)->next(f);
    if (!got.ok()) check(got.error(), uri.c_str());
    if (!*got) break;
    r.frames.push_back(f);
  }
  return r;
}

// A .klg log and its side file; `color` false writes frames without colour (size 0).
inline void write_klg(const std::string& path, const Recording& r, const KlgWriteOptions& options, bool color = true,
                      bool side_file = true) {
  KlgWriter w;
  check(w.open(path, r.intrinsics.width, r.intrinsics.height, options), path.c_str());
  for (Frame f : r.frames) {
    if (!color) f.color = Image<Rgb8>();
    check(w.write(f), path.c_str());
  }
  check(w.close(), path.c_str());
  if (side_file) check(write_klg_side_file(path, r.intrinsics), path.c_str());
}

inline void write_tum(const std::string& dir, const Recording& r) {
  TumWriter w;
  check(w.open(dir, r.intrinsics), dir.c_str());
  for (const Frame& f : r.frames) check(w.write(f), dir.c_str());
  check(w.close(), dir.c_str());
}

// A 7-Scenes sequence folder: frame-NNNNNN.color.png, .depth.png (millimetres), .pose.txt (4x4).
inline void write_7scenes(const std::string& dir, const Recording& r) {
  std::filesystem::create_directories(dir);
  for (std::size_t i = 0; i < r.frames.size(); ++i) {
    const Frame& f = r.frames[i];
    char stem[64];
    std::snprintf(stem, sizeof stem, "%s/frame-%06zu", dir.c_str(), i);
    check(write_png(std::string(stem) + ".color.png", f.color.view()), stem);
    Image<uint16_t> mm(f.depth.width(), f.depth.height());
    for (int y = 0; y < mm.height(); ++y)
      for (int x = 0; x < mm.width(); ++x) mm(x, y) = static_cast<uint16_t>(f.depth(x, y) * 1000.0f + 0.5f);
    check(write_png(std::string(stem) + ".depth.png", mm.view()), stem);
    const Eigen::Matrix4d m = f.T_wc.matrix();
    std::string text;
    for (int row = 0; row < 4; ++row) {
      char line[160];
      std::snprintf(line, sizeof line, "%.9g\t%.9g\t%.9g\t%.9g\n", m(row, 0), m(row, 1), m(row, 2), m(row, 3));
      text += line;
    }
    std::FILE* p = std::fopen((std::string(stem) + ".pose.txt").c_str(), "wb");
    if (p == nullptr || std::fwrite(text.data(), 1, text.size(), p) != text.size()) std::abort();
    std::fclose(p);
  }
}

// A field log of the frames (calibration, depth, colour, reference poses), as `convert --to mcap:`.
inline void write_mcap(const std::string& path, const Recording& r, McapLogOptions options) {
  options.sync = false;
  McapFrameLog log;
  check(log.open(path, options, r.intrinsics.width, r.intrinsics.height, r.intrinsics), path.c_str());
  auto enc = log.make_encoder();
  for (const Frame& f : r.frames) {
    check(log.log_frame(f, *enc), path.c_str());
    check(log.log_pose(f.timestamp, f.T_wc, *enc), path.c_str());
  }
  check(log.close(), path.c_str());
}

inline std::string read_file(const std::string& path) {
  std::string s;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) std::abort();
  char buf[65536];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) s.append(buf, n);
  std::fclose(f);
  return s;
}

}  // namespace ef::fuzz
