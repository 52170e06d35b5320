// report.html in the run folder (issue 33): one self-contained page (no script, no network: styles
// inline, pictures as data: URIs, charts as inline SVG) with what a run did: the map's picture, the
// camera's path from above over the map's outline, the stages' times, the mapping rate over the
// run, the counters, the classes of the map, and the configuration used.
//
// Written streaming, through a fixed buffer: the pictures are base64-encoded from their PNG files
// in 48 kB pieces, so the page costs no memory beyond the preview's (memory plan: "map preview").
// Whole or absent (io/durable_file.h FileReplacement).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/result.h"
#include "core/se3.h"
#include "core/stage_stats.h"
#include "io/ply_writer.h"

namespace ef::pipeline {

// What a run keeps for its report while it runs (fixed, reserved at start-up: the memory plan's
// "run report" part): the rate's samples and the source's reference poses (every k-th).
inline constexpr std::size_t kReportRateSamples = 512;
inline constexpr std::size_t kReportReferencePoses = 4096;

// frames mapped by `seconds` after the start: the rate over time is the slope between samples.
struct RateSample {
  double seconds = 0;
  int64_t frames = 0;
};

struct ReportInputs {
  std::string title;    // the source URI
  std::string state;    // stats.json's end state: finished, stopped, camera lost, failed: ...
  int64_t frames = 0;
  double seconds = 0;
  std::vector<std::pair<std::string, std::string>> facts;  // more "key: value" lines (resolution, version...)
  const StageStats* stats = nullptr;                       // stages and counters
  std::string preview_png;                                 // preview.png to embed ("" = none)
  std::vector<int64_t> class_counts;                       // surfels per class id 0..13 (empty: no labels)
  std::vector<RateSample> rate;
  std::string config_text;  // config.yaml's
};

// The map's outline from above for the path chart: at most `max_points` surfel centres, and the path.
// `reference`: the source's reference camera centres in the map's frame (aligned), drawn dashed.
struct TopView {
  std::vector<std::pair<float, float>> outline;  // image coordinates, 0..1000 x 0..(1000 * aspect)
  std::vector<std::pair<float, float>> path, reference;
  float height = 750;
};
TopView top_view(const SurfelCloudView& cloud, const std::vector<SE3>& path,
                 const std::vector<Eigen::Vector3d>& reference = {}, int max_points = 3000);

// Writes the page. Errors name the file (a PNG that cannot be read is left out with a note, not an
// error: the page still says everything else).
Status write_run_report(const std::string& path, const ReportInputs& in, const TopView& top);

}  // namespace ef::pipeline
