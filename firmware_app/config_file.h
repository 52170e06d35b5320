// Reading the configuration of `edgefusion run` and `edgefusion plan` (pipeline/run_config.h): from
// defaults, then an optional YAML file, then the command line (each later one overrides the
// earlier). Every key, flat name and flag comes from the options tables (pipeline::config_keys()).
//
// The file is YAML (read with yaml-cpp). Options sit at the top level or in sections; a section key
// that has an older flat name can be given either way, so both of these set the same option:
//
//   mapping: {surfel_capacity: 500000}        surfel_capacity: 500000
//   labels: {every: 5}                        label_every: 5
//
// A URI such as `synthetic:` or `openni2:` ends in ':', which YAML reads as a nested key: the reader
// quotes such a plain value on a `key: value` line itself (inside `{ }`, write it in quotes).
//
// Errors name the file, the line, the key (as written: `crf_iterations`, or the section path
// `crf.iterations`) and the bad value. Unknown keys, a key given twice and YAML syntax errors are
// errors too. The checks between keys and against the machine are RunConfig::validate()'s.
#pragma once

#include <string>
#include <vector>

#include "args.h"
#include "core/result.h"
#include "pipeline/run_config.h"

namespace ef::app {

using pipeline::RunConfig;

// Applies the keys of a YAML configuration file to `config`. Errors (kInvalidArgument; kNotFound
// when the file cannot be opened) name the file, the line, the key path and the bad value; a file
// with an error leaves `config` as it was.
Status apply_config_file(const std::string& path, RunConfig& config);

// The same for the text of a file; `name` stands for the file in messages.
Status apply_config_text(const std::string& text, const std::string& name, RunConfig& config);

// Applies one option to `config`. `key` is a section path ("crf.iterations") or a flat name
// ("crf_iterations", "labels"); `value` the text as in the file. Errors name `where`, the key as
// given and the value.
Status apply_config_value(const std::string& key, const std::string& value, const std::string& where,
                          RunConfig& config);

// The command-line options of `run` and `plan`: --config FILE, then the flag of every key that has
// one (--source, --resolution, ..., --no-labels, --threads), with its help from the key's table.
const std::vector<OptionSpec>& config_override_options();

// Builds the configuration of a command line parsed with config_override_options(): defaults, then
// --config FILE, then every flag. Errors name the file / option, the key and the value. Does not
// validate() the result: the commands do, after it.
Result<RunConfig> config_from_args(const ParsedArgs& args);
// The same on top of `base_file` (a resumed run's config.yaml) instead of --config.
Result<RunConfig> config_from_args(const ParsedArgs& args, const std::string& base_file);

}  // namespace ef::app
