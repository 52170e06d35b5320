// The commands of `edgefusion`. Each takes the full argv (argv[1] is the command name) and returns
// the exit code: 0 success, 1 failure while running, 2 usage error; `run` also 3 (kExitCameraLost).
#pragma once

#include <string>
#include <vector>

#include "args.h"
#include "core/result.h"

namespace ef::app {

// `run`'s exit status when its live camera vanished: the outputs are complete, and the systemd unit
// restarts on it (Restart=on-failure; 2, a configuration error, is never restarted).
inline constexpr int kExitCameraLost = 3;

int cmd_run(int argc, char** argv);
int cmd_eval(int argc, char** argv);
int cmd_convert(int argc, char** argv);
int cmd_segment(int argc, char** argv);
int cmd_model(int argc, char** argv);
int cmd_plan(int argc, char** argv);
int cmd_export(int argc, char** argv);
int cmd_log(int argc, char** argv);
int cmd_view(int argc, char** argv);

// The option tables of the commands, as each one's parse_args() takes them (defined beside each
// command), and the list of every command's syntax: what `edgefusion <words> ...` accepts before it
// does anything. The command-line fuzz target (tests/fuzz/fuzz_args.cpp) parses with these.
const std::vector<OptionSpec>& run_command_options();
const std::vector<OptionSpec>& plan_command_options();
const std::vector<OptionSpec>& eval_ate_options();
const std::vector<OptionSpec>& eval_rpe_options();
const std::vector<OptionSpec>& eval_labels_options();
const std::vector<OptionSpec>& convert_options();
const std::vector<OptionSpec>& log_options();
const std::vector<OptionSpec>& segment_options();
const std::vector<OptionSpec>& model_info_options();
const std::vector<OptionSpec>& model_import_options();
const std::vector<OptionSpec>& export_options();
const std::vector<OptionSpec>& view_options();

struct CommandSyntax {
  const char* words;      // "run", "eval ate"
  int first;              // argv index of its first option or argument (2; 3 after a sub-command)
  int positionals;        // positional arguments it takes (parse_args' positional_count)
  const std::vector<OptionSpec>& (*options)();
  bool takes_config;      // run and plan: the flags of the configuration keys (config_file.h)
};
const std::vector<CommandSyntax>& command_syntaxes();

// The list of source URI forms, for help texts.
const char* source_uri_help_text();

// Prints "edgefusion <command>: <error>" to stderr and returns `code`.
int report_error(const char* command, const Error& err, int code);
// Prints "edgefusion <command>: warning: <text>" to stderr when `text` is not empty (a source's
// SourceInfo::warning: what it recovered from).
void report_warning(const char* command, const std::string& text);

}  // namespace ef::app
