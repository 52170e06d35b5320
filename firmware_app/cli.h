#pragma once

namespace ef::app {

// Parses argv and runs one command (run, eval, convert, segment, model). Returns the process exit code:
// 0 success, 1 runtime failure, 2 usage error.
int run_cli(int argc, char** argv);

}  // namespace ef::app
