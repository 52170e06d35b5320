// libFuzzer target for the text parsers: byte 0 picks the parser, the rest is the file's text.
//   0 TUM rgb/depth list   1 TUM groundtruth   2 TUM intrinsics.txt
//   3 7-Scenes pose        4 7-Scenes camera matrix   5 source URI (+ query key check)
//   6 a .klg's side file FILE.intrinsics.txt (size and camera; read from an in-memory file)
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.h"
#include "io/frame_source.h"
#include "io/klg_format.h"
#include "io/sevenscenes_source.h"
#include "io/tum_source.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  switch (data[0] % 7) {
    case 0: {
      auto r = ef::parse_tum_list(text, "rgb.txt");
      if (r.ok() && r->size() > 1) {
        // Associate the list with itself shifted: exercises the matcher on fuzzed timestamps.
        std::vector<double> a, b;
        for (const auto& e : *r) {
          a.push_back(e.timestamp);
          b.push_back(e.timestamp + 0.01);
        }
        (void)ef::associate_timestamps(a, b, ef::kTumMaxTimeDifference);
      }
      break;
    }
    case 1: {
      auto r = ef::parse_tum_groundtruth(text, "groundtruth.txt");
      if (r.ok() && !r->empty()) {
        ef::SE3 pose;
        (void)ef::lookup_pose(*r, r->front().timestamp + 0.005, ef::kTumMaxTimeDifference, pose);
      }
      break;
    }
    case 2: (void)ef::parse_tum_intrinsics(text, "intrinsics.txt"); break;
    case 3: (void)ef::parse_7scenes_pose(text, "frame-000000.pose.txt"); break;
    case 4: (void)ef::parse_7scenes_intrinsics(text, "camera-intrinsics.txt"); break;
    case 6: {
      static ef::fuzz::MemFile file;
      (void)ef::read_klg_side_file(file.write(data + 1, size - 1));
      break;
    }
    case 5: {
      auto r = ef::parse_source_uri(text);
      if (r.ok()) (void)ef::check_query_keys(*r, {"size", "fx", "fy", "cx", "cy"});
      break;
    }
  }
  return 0;
}
