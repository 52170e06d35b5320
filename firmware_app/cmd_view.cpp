// `edgefusion view MAP --out PNG`: a picture of any map, drawn as `run` draws its preview.png
// (pipeline/map_preview.h): a run's map.ply or any surfel PLY, a run folder, or a checkpoint.
#include <cstdio>
#include <filesystem>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "args.h"
#include "commands.h"
#include "io/ply_writer.h"
#include "pipeline/checkpoint.h"
#include "pipeline/map_preview.h"
#include "semantic/label_store.h"
#include "slam/surfel_slam.h"

namespace ef::app {

namespace {

namespace fs = std::filesystem;

const std::vector<OptionSpec> kViewOptions = {
    {"--out", "PNG", "the picture to write (required)"},
    {"--top", "", "straight down instead of the oblique view"},
    {"--pose", "\"TX TY TZ QX QY QZ QW\"", "draw from this camera (camera-to-world, TUM order, metres) instead"},
    {"--trajectory", "FILE", "the camera path to draw (TUM); default the trajectory.txt beside the map"},
    {"--size", "WxH", "each of the two panels, pixels (default 640x480, 64..4096)"},
};

// A map given as a file or folder: its surfels, their classes when it has them, and the folder
// whose trajectory.txt goes with it.
struct LoadedMap {
  SurfelCloud cloud;                  // a PLY's
  std::optional<slam::SurfelPool> pool;  // a checkpoint's
  std::vector<uint8_t> class_id;
  std::vector<float> class_prob;
  SurfelCloudView view;
  std::string folder, what;
};

Result<LoadedMap> load_map(const std::string& map) {
  LoadedMap m;
  std::error_code ec;
  fs::path p(map);
  if (fs::is_directory(p, ec) && fs::exists(p / "map.ply", ec)) p /= "map.ply";
  m.folder = fs::is_directory(p, ec) ? p.string() : p.parent_path().string();
  if (p.extension() == ".ply") {
    EF_ASSIGN_OR_RETURN(m.cloud, read_surfel_ply(p.string()));
    m.view = m.cloud.view();
    m.what = p.string();
    return m;
  }
  if (!fs::is_directory(p, ec) && p.extension() != ".efs")
    return error(ErrorCode::kInvalidArgument, map + ": not a map (a .ply file, a run folder or a checkpoint .efs)");
  // A run folder without map.ply (a killed run), or a checkpoint: the newest valid checkpoint.
  EF_ASSIGN_OR_RETURN(pipeline::FoundCheckpoint found, pipeline::find_checkpoint(m.folder));
  EF_ASSIGN_OR_RETURN(slam::SurfelPool pool, pipeline::load_checkpoint_pool(found));
  m.pool.emplace(std::move(pool));
  m.view = slam::surfel_cloud_view(*m.pool);
  const std::size_t n = static_cast<std::size_t>(m.pool->size());
  if (found.meta.labels) {
    m.class_id.resize(n);
    m.class_prob.resize(n);
    semantic::label_summary(m.pool->labels(), n, m.class_id.data(), m.class_prob.data());
    m.view.class_id = Column<uint8_t>(m.class_id.data());
    m.view.class_prob = Column<float>(m.class_prob.data());
  } else {
    m.view.class_id = Column<uint8_t>();
  }
  m.what = found.reader->path() + " (" + std::to_string(found.meta.frames) + " frames)";
  return m;
}

}  // namespace

int cmd_view(int argc, char** argv) {
  constexpr const char* kCmd = "edgefusion view";
  if (wants_help(argc, argv, 2)) {
    std::printf("%s", format_help("edgefusion view MAP --out PNG [--top | --pose \"TX TY TZ QX QY QZ QW\"] "
                                  "[--trajectory FILE] [--size WxH]",
                                  "Draws a map as `run` draws its preview.png: two panels from one viewpoint, the\n"
                                  "surfels' colours and their classes in the paper's palette, the camera's path\n"
                                  "(green start, red end) and a legend of the classes with their share of the map.\n"
                                  "MAP: a surfel PLY (run's map.ply), a run folder (its map.ply, or its newest\n"
                                  "checkpoint when the run was killed before writing one), or a checkpoint .efs.\n"
                                  "The default viewpoint frames the map obliquely from above, behind the direction\n"
                                  "the camera mostly looked.",
                                  kViewOptions)
                          .c_str());
    return 0;
  }
  auto args = parse_args(kCmd, kViewOptions, 1, argc, argv, 2);
  if (!args.ok()) return report_error(kCmd, args.error(), 2);
  if (!args->has("--out")) return report_error(kCmd, error(ErrorCode::kInvalidArgument, "--out PNG is required"), 2);
  if (args->has("--top") && args->has("--pose"))
    return report_error(kCmd, error(ErrorCode::kInvalidArgument, "--top and --pose choose the viewpoint both: give one"), 2);
  pipeline::PreviewOptions options;
  if (args->has("--size")) {
    int w = 0, h = 0;
    char x = 0, extra = 0;
    std::istringstream s(args->get("--size"));
    if (!(s >> w >> x >> h) || x != 'x' || (s >> extra) || w < 64 || h < 64 || w > 4096 || h > 4096)
      return report_error(kCmd, error(ErrorCode::kInvalidArgument, "--size '" + args->get("--size") +
                                                                       "' is not WxH within 64x64..4096x4096"),
                          2);
    options.width = w;
    options.height = h;
  }
  options.top = args->has("--top");
  if (args->has("--pose")) {
    auto pose = parse_pose(args->get("--pose"), "--pose");
    if (!pose.ok()) return report_error(kCmd, pose.error(), 2);
    options.pose = *pose;
  }

  auto map = load_map(args->positionals()[0]);
  if (!map.ok()) return report_error(kCmd, map.error(), 1);
  std::vector<SE3> path;
  const std::string traj = args->has("--trajectory") ? args->get("--trajectory")
                                                      : (fs::path(map->folder) / "trajectory.txt").string();
  std::error_code ec;
  if (args->has("--trajectory") || fs::exists(traj, ec)) {
    auto read = pipeline::read_preview_path(traj);
    if (!read.ok()) return report_error(kCmd, read.error(), 1);
    path = std::move(*read);
  }
  options.title = map->what;
  pipeline::PreviewStats stats;
  const std::string out = args->get("--out");
  if (Status s = pipeline::write_map_preview(out, map->view, path, options, &stats); !s.ok())
    return report_error(kCmd, s.error(), 1);
  std::printf("view: %s (%lld surfels, %lld drawn, %lld poses of the path)\n", out.c_str(),
              static_cast<long long>(stats.surfels), static_cast<long long>(stats.drawn),
              static_cast<long long>(path.size()));
  return 0;
}

const std::vector<OptionSpec>& view_options() { return kViewOptions; }

}  // namespace ef::app
