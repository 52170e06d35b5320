// The commands of `edgefusion`. Each takes the full argv (argv[1] is the command name) and returns
// the exit code: 0 success, 1 failure while running, 2 usage error; `run` also 3 (kExitCameraLost).
#pragma once

#include <string>

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

// The list of source URI forms, for help texts.
const char* source_uri_help_text();

// Prints "edgefusion <command>: <error>" to stderr and returns `code`.
int report_error(const char* command, const Error& err, int code);
// Prints "edgefusion <command>: warning: <text>" to stderr when `text` is not empty (a source's
// SourceInfo::warning: what it recovered from).
void report_warning(const char* command, const std::string& text);

}  // namespace ef::app
