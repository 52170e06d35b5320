// Reading the configuration of `edgefusion run` and `edgefusion plan` (pipeline/run_config.h) from a
// YAML file and the command line.
#pragma once

#include <string>
#include <vector>

#include "args.h"
#include "core/result.h"
#include "pipeline/run_config.h"

namespace ef::app {

using pipeline::RunConfig;

// A complete YAML configuration file: every option in its section, with its unit, range and
// default as a comment. Reading it back (apply_config_file) gives this configuration again.
// Empty strings (out, model, labels out) are written as commented-out keys.
std::string describe_config(const RunConfig& config);

// Applies the keys of a YAML configuration file to `config`. Errors (kInvalidArgument; kNotFound
// when the file cannot be opened) name the file, the line, the key path and the bad value.
Status apply_config_file(const std::string& path, RunConfig& config);

// The same for the text of a file; `name` stands for the file in messages.
Status apply_config_text(const std::string& text, const std::string& name, RunConfig& config);

// Applies one option to `config`. `key` is a section path ("crf.iterations") or a flat name
// ("crf_iterations", "labels"); `value` the text as in the file. Errors name `where`, the key as
// given and the value.
Status apply_config_value(const std::string& key, const std::string& value, const std::string& where,
                          RunConfig& config);

// Every option key, as a section path ("source", "mapping.surfel_capacity", ...), in file order.
std::vector<std::string> config_keys();

// Command-line options that override configuration keys, shared by `run` and `plan`: --config,
// --source, --resolution, --frames, --out, --quiet, --model, --no-labels, --label-every,
// --labels-out, --labels-out-every, --crf-every, --crf-final, --crf-iterations, --surfel-capacity,
// --memory-budget-mb, --threads.
const std::vector<OptionSpec>& config_override_options();

// Builds the configuration of a command line parsed with config_override_options(): defaults, then
// --config FILE, then every override. Errors name the file / option, the key and the value.
Result<RunConfig> config_from_args(const ParsedArgs& args);

}  // namespace ef::app
