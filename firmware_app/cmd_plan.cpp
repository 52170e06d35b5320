// `edgefusion plan`: the fixed memory a run of this configuration would allocate at start-up, part
// by part (src/pipeline/memory_plan.h), against the configured budget. Runs nothing.
#include <cstdio>
#include <string>

#include "args.h"
#include "commands.h"
#include "pipeline/memory_plan.h"
#include "config_file.h"

namespace ef::app {

using namespace ef::pipeline;  // the run pipeline, its configuration and memory plan

namespace {

std::string plan_help() {
  return format_help(
      "edgefusion plan [--config FILE] [the options of run]",
      "Prints the bytes each part of `edgefusion run` would allocate at start-up with this\n"
      "configuration (frames, SLAM buffers, the surfel pool with its label store, the segmenter's\n"
      "model, arena and buffers, label fusion, the dense CRF when on, the class columns of map.ply),\n"
      "the total and the budget (memory.budget_mb, MB = 10^6 bytes). Nothing large is allocated and the\n"
      "source is not opened (its frame size comes from size=WxH in its URI, else 640x480); the model\n"
      "file is read when labels are on. Takes the same options as run, so `run` can be replaced by\n"
      "`plan` in any command line.\n"
      "Exit status: 0 within the budget, 1 over it (a run would refuse to start), 2 a configuration error.\n\n"
      "The configuration file, with every key, its unit and its default:\n\n" +
          describe_config(RunConfig()),
      config_override_options());
}

}  // namespace

int cmd_plan(int argc, char** argv) {
  constexpr const char* kCmd = "edgefusion plan";
  if (wants_help(argc, argv, 2)) {
    std::printf("%s", plan_help().c_str());
    return 0;
  }
  auto args = parse_args(kCmd, config_override_options(), 0, argc, argv, 2);
  if (!args.ok()) return report_error(kCmd, args.error(), 2);
  auto config = config_from_args(*args);
  if (!config.ok()) return report_error(kCmd, config.error(), 2);
  auto plan = plan_memory(*config);
  if (!plan.ok()) return report_error(kCmd, plan.error(), 2);

  std::printf("memory plan: source %s, working %dx%d, %lld surfels, labels %s, CRF %s\n", config->source.c_str(),
              config->width, config->height, static_cast<long long>(config->surfel_capacity),
              config->labels ? "on" : "off", config->labels && (config->crf_every > 0 || config->crf_final) ? "on" : "off");
  std::printf("%s", plan->table().c_str());
  if (!plan->within_budget()) {
    std::fprintf(stderr,
                 "%s: over budget: %.1f MB planned, budget %lld MB (memory.budget_mb); a run would refuse to start. "
                 "Lower mapping.surfel_capacity (or the resolution, or turn the CRF off) or raise memory.budget_mb.\n",
                 kCmd, static_cast<double>(plan->total_bytes) / 1e6, static_cast<long long>(config->memory_budget_mb));
    return 1;
  }
  std::printf("within budget: %.1f of %lld MB\n", static_cast<double>(plan->total_bytes) / 1e6,
              static_cast<long long>(config->memory_budget_mb));
  return 0;
}

}  // namespace ef::app
