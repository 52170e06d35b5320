// `edgefusion plan`: everything `run` checks before it starts, without running: the configuration,
// the source, the model, and the fixed memory a run of this configuration would allocate at
// start-up, part by part (pipeline/memory_plan.h), against the configured budget.
#include <cstdio>
#include <string>
#include <vector>

#include "args.h"
#include "commands.h"
#include "config_file.h"
#include "pipeline/memory_plan.h"
#include "sources/open_source.h"

namespace ef::app {

using namespace ef::pipeline;  // the run's configuration and memory plan

namespace {

const std::vector<OptionSpec>& plan_options() {
  static const std::vector<OptionSpec> specs = [] {
    std::vector<OptionSpec> s = config_override_options();
    s.push_back({"--keys", "", "print every configuration key as a Markdown table (the README's list) and exit"});
    return s;
  }();
  return specs;
}

std::string plan_help() {
  return format_help(
      "edgefusion plan [--config FILE] [the options of run]",
      "Checks a run's configuration as `run` does before it starts, and prints the bytes each part of\n"
      "`edgefusion run` would allocate at start-up (frames, SLAM buffers, the surfel pool with its label\n"
      "store, the segmenter's model, arena and buffers, label fusion, the dense CRF when on, the class\n"
      "columns of map.ply), the total and the budget (memory.budget_mb, MB = 10^6 bytes). Nothing large\n"
      "is allocated. A recording is opened and closed again (its frame size); a live camera is not\n"
      "touched (its size is the URI's size=, else the 640x480 it is asked for); the model file is read\n"
      "when labels are on. Takes the same options as run, so `run` can be replaced by `plan` in any\n"
      "command line, and refuses whatever `run` would refuse before its first frame.\n"
      "Exit status: 0 within the budget, 1 over it (a run would refuse to start), 2 a configuration,\n"
      "source or model error.\n\n"
      "The configuration file, with every key, its unit and its default:\n\n" +
          RunConfig().describe(),
      plan_options());
}

}  // namespace

int cmd_plan(int argc, char** argv) {
  constexpr const char* kCmd = "edgefusion plan";
  if (wants_help(argc, argv, 2)) {
    std::printf("%s", plan_help().c_str());
    return 0;
  }
  auto args = parse_args(kCmd, plan_options(), 0, argc, argv, 2);
  if (!args.ok()) return report_error(kCmd, args.error(), 2);
  if (args->has("--keys")) {
    std::printf("%s", config_keys_markdown().c_str());
    return 0;
  }
  auto config = config_from_args(*args);
  if (!config.ok()) return report_error(kCmd, config.error(), 2);
  // The order of `run`: the configuration alone, then the source, then what depends on both.
  if (Status s = config->validate(); !s.ok()) return report_error(kCmd, s.error(), 2);
  auto probe = probe_source(config->run.source);
  if (!probe.ok()) return report_error(kCmd, probe.error(), 2);
  auto plan = check_and_plan(*config, *probe);
  if (!plan.ok()) return report_error(kCmd, plan.error(), 2);

  std::printf("memory plan: source %s, working %dx%d, %lld surfels, labels %s, CRF %s\n", config->run.source.c_str(),
              config->run.resolution.width, config->run.resolution.height,
              static_cast<long long>(config->mapping.pool.capacity), config->labels.enabled ? "on" : "off",
              config->labels.enabled && config->crf.on() ? "on" : "off");
  std::printf("%s", plan->table().c_str());
  if (!plan->within_budget()) {
    std::fprintf(stderr,
                 "%s: over budget: %.1f MB planned, budget %lld MB (memory.budget_mb); a run would refuse to start. "
                 "Lower mapping.surfel_capacity (or the resolution, or turn the CRF off) or raise memory.budget_mb.\n",
                 kCmd, static_cast<double>(plan->total_bytes) / 1e6, static_cast<long long>(config->memory.budget_mb));
    return 1;
  }
  std::printf("within budget: %.1f of %lld MB\n", static_cast<double>(plan->total_bytes) / 1e6,
              static_cast<long long>(config->memory.budget_mb));
  return 0;
}

const std::vector<OptionSpec>& plan_command_options() { return plan_options(); }

}  // namespace ef::app
