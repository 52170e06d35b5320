// Render speed of the synthetic source on one thread: frames per second (median over repeats) at
// 640x480 and 320x240, with and without the Kinect-like noise, through the ideal and the Kinect-like
// colour camera (camera_model.h: five renders per frame for the motion blur), for the default room
// and loop.
//
//   bench_synth_render [room] [repeats]     (defaults: living_room, 5 repeats of 30 frames)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "io/frame_source.h"
#include "synth/synthetic_source.h"

int main(int argc, char** argv) {
  const std::string room = argc > 1 ? argv[1] : "living_room";
  const int repeats = argc > 2 ? std::max(1, std::atoi(argv[2])) : 5;
  constexpr int kFrames = 30;  // frames per repeat, spread over a 300-frame loop
  std::printf("synthetic room '%s', %d repeats of %d frames, one thread\n", room.c_str(), repeats, kFrames);
  std::printf("%-10s %-6s %-7s %12s %12s\n", "size", "noise", "camera", "median fps", "ms/frame");
  for (const char* size : {"640x480", "320x240"}) {
    for (const char* camera : {"ideal", "kinect"}) {
      for (const char* noise : {"0", "1"}) {
        const std::string text =
            "synthetic:" + room + "?frames=300&size=" + size + "&noise=" + noise + "&camera=" + camera;
        auto uri = ef::parse_source_uri(text);
        if (!uri.ok()) { std::fprintf(stderr, "%s\n", ef::to_string(uri.error()).c_str()); return 1; }
        auto options = ef::synth::parse_synthetic_options(*uri);
        if (!options.ok()) { std::fprintf(stderr, "%s\n", ef::to_string(options.error()).c_str()); return 1; }
        auto src = ef::synth::open_synthetic_source(*options, text);
        if (!src.ok()) { std::fprintf(stderr, "%s\n", ef::to_string(src.error()).c_str()); return 1; }
        ef::Frame frame;
        if (!(*src)->render(0, frame).ok()) return 1;  // warm up, allocate
        std::vector<double> fps;
        for (int r = 0; r < repeats; ++r) {
          const auto t0 = std::chrono::steady_clock::now();
          for (int i = 0; i < kFrames; ++i)
            if (!(*src)->render(i * 10, frame).ok()) return 1;
          const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          fps.push_back(kFrames / s);
        }
        std::sort(fps.begin(), fps.end());
        const double med = fps[fps.size() / 2];
        std::printf("%-10s %-6s %-7s %12.1f %12.2f\n", size, noise, camera, med, 1000.0 / med);
      }
    }
  }
  return 0;
}
