#include "cli.h"

#include <cstdio>
#include <cstring>
#include <string>

#include "commands.h"
#include "platform/cpu/cpu_features.h"
#include "sources/open_source.h"
#include "version.h"

namespace ef::app {

namespace {

constexpr const char* kVersion = EF_VERSION;  // generated/version.h (cmake/version.cmake)

void print_main_help() {
  std::printf(
      "edgefusion %s: dense 3D semantic mapping on the CPU (SemanticFusion on surfels)\n\n"
      "Usage: edgefusion <command> [options]     (edgefusion <command> --help for each)\n\n"
      "Commands:\n"
      "  run       map a source: writes trajectory.txt, map.ply, preview.png (when a map exists) and stats.json\n"
      "  eval      evaluate a trajectory (ate, rpe) or label images (labels)\n"
      "  convert   turn any source into an ElasticFusion .klg log, a TUM RGB-D folder or an MCAP field log\n"
      "  log       record a field log (MCAP) and nothing else: the low-power mode; map it later with run\n"
      "  segment   run the segmentation network on a source: class-id images per frame\n"
      "  model     inspect a network (info) or quantise an ONNX one to .efm (import)\n"
      "  plan      print the memory a run of a configuration allocates, part by part, against its budget\n"
      "  export    write the map of a run's newest checkpoint as a PLY file (a run killed before its end)\n"
      "  view      draw a map (PLY, run folder or checkpoint) as a picture: colour and classes, the camera's path\n"
      "  version   print the version and the CPU paths this machine can use\n\n"
      "Sources: %s\n",
      kVersion, source_uri_help_text());
}

}  // namespace

int run_cli(int argc, char** argv) {
  if (argc < 2) {
    print_main_help();
    return 2;
  }
  const std::string cmd = argv[1];
  if (cmd == "-h" || cmd == "--help" || cmd == "help") {
    print_main_help();
    return 0;
  }
  if (cmd == "--version" || cmd == "version") {
    std::printf("edgefusion %s\ncpu paths: %s\n", kVersion, cpu_features().describe().c_str());
    return 0;
  }
  if (cmd == "run") return cmd_run(argc, argv);
  if (cmd == "eval") return cmd_eval(argc, argv);
  if (cmd == "convert") return cmd_convert(argc, argv);
  if (cmd == "segment") return cmd_segment(argc, argv);
  if (cmd == "model") return cmd_model(argc, argv);
  if (cmd == "plan") return cmd_plan(argc, argv);
  if (cmd == "export") return cmd_export(argc, argv);
  if (cmd == "log") return cmd_log(argc, argv);
  if (cmd == "view") return cmd_view(argc, argv);
  std::fprintf(stderr,
               "edgefusion: unknown command '%s' (expected run, eval, convert, log, segment, model, plan, export, view, version; see --help)\n",
               cmd.c_str());
  return 2;
}

}  // namespace ef::app

namespace ef::app {

const char* source_uri_help_text() { return source_uri_help(); }

// The positional counts and first indices are those each command passes to parse_args().
const std::vector<CommandSyntax>& command_syntaxes() {
  static const std::vector<CommandSyntax> all = {
      {"run", 2, 0, run_command_options, true},          {"plan", 2, 0, plan_command_options, true},
      {"eval ate", 3, 2, eval_ate_options, false},       {"eval rpe", 3, 2, eval_rpe_options, false},
      {"eval labels", 3, 2, eval_labels_options, false}, {"convert", 2, 0, convert_options, false},
      {"log", 2, 0, log_options, false},                 {"segment", 2, 0, segment_options, false},
      {"model info", 3, 1, model_info_options, false},   {"model import", 3, 0, model_import_options, false},
      {"export", 2, 1, export_options, false},           {"view", 2, 1, view_options, false},
  };
  return all;
}

int report_error(const char* command, const Error& err, int code) {
  std::fprintf(stderr, "%s: error: %s\n", command, to_string(err).c_str());
  return code;
}

void report_warning(const char* command, const std::string& text) {
  if (!text.empty()) std::fprintf(stderr, "%s: warning: %s\n", command, text.c_str());
}

}  // namespace ef::app
