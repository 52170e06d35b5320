// Runs the `edgefusion` command line in-process (run_cli) and captures what it prints.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "firmware_app/cli.h"

namespace ef::app {

struct CliResult {
  int code;         // run_cli's return value (the process exit code)
  std::string out;  // stdout
  std::string err;  // stderr
};

// args: everything after the program name, e.g. {"eval", "ate", "gt.txt", "est.txt"}.
inline CliResult cli(std::vector<std::string> args) {
  args.insert(args.begin(), "edgefusion");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  const int code = run_cli(static_cast<int>(args.size()), argv.data());
  return CliResult{code, testing::internal::GetCapturedStdout(), testing::internal::GetCapturedStderr()};
}

// The number of a "key value" line of `out` (what `edgefusion eval` prints); NaN when there is none.
inline double metric(const std::string& out, const std::string& key) {
  std::istringstream in(out);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string k, rest;
    double v;
    if (fields >> k >> v && !(fields >> rest) && k == key) return v;
  }
  return NAN;
}

// The whole text of a file ("" when it cannot be read).
inline std::string read_file(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace ef::app
