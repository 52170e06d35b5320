// `edgefusion export DIR`: the map of a run's newest checkpoint as a PLY file, for a run that was
// killed before it wrote map.ply (pipeline/checkpoint.h).
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "args.h"
#include "commands.h"
#include "io/ply_writer.h"
#include "pipeline/checkpoint.h"
#include "semantic/label_store.h"

namespace ef::app {

namespace {

const std::vector<OptionSpec> kExportOptions = {
    {"--out", "FILE", "the PLY file to write; default DIR/map.ply"},
};

}  // namespace

int cmd_export(int argc, char** argv) {
  constexpr const char* kCmd = "edgefusion export";
  if (wants_help(argc, argv, 2)) {
    std::printf("%s", format_help("edgefusion export DIR [--out FILE]",
                                  "Writes the map of the run in DIR, as its newest checkpoint holds it\n"
                                  "(checkpoint.efs, or checkpoint.prev.efs when that one is corrupt), as a PLY file\n"
                                  "like run's map.ply: for a run killed before it wrote its outputs. The run can\n"
                                  "also go on: edgefusion run --resume DIR.",
                                  kExportOptions)
                          .c_str());
    return 0;
  }
  auto args = parse_args(kCmd, kExportOptions, 1, argc, argv, 2);
  if (!args.ok()) return report_error(kCmd, args.error(), 2);
  const std::string dir = args->positionals()[0];
  const std::string out = args->has("--out") ? args->get("--out") : (std::filesystem::path(dir) / "map.ply").string();

  auto found = pipeline::find_checkpoint(dir);
  if (!found.ok()) return report_error(kCmd, found.error(), 1);
  report_warning(kCmd, found->warning);
  auto pool = pipeline::load_checkpoint_pool(*found);
  if (!pool.ok()) return report_error(kCmd, pool.error(), 1);

  SurfelCloudView cloud = slam::surfel_cloud_view(*pool);
  const std::size_t n = static_cast<std::size_t>(pool->size());
  std::vector<uint8_t> class_id;
  std::vector<float> class_prob;
  if (found->meta.labels) {
    class_id.resize(n);
    class_prob.resize(n);
    semantic::label_summary(pool->labels(), n, class_id.data(), class_prob.data());
    cloud.class_id = Column<uint8_t>(class_id.data());
    cloud.class_prob = Column<float>(class_prob.data());
  }
  const std::string comment = "edgefusion map of the checkpoint " + found->reader->path() + ", " +
                              std::to_string(found->meta.frames) + " frames";
  if (Status s = write_surfel_ply(out, cloud, comment); !s.ok()) return report_error(kCmd, s.error(), 1);
  std::printf("map: %s (%zu surfels, %lld frames mapped)\n", out.c_str(), n,
              static_cast<long long>(found->meta.frames));
  return 0;
}

const std::vector<OptionSpec>& export_options() { return kExportOptions; }

}  // namespace ef::app
