// A small command-line parser for `edgefusion <command> [options]`: declared options only, each
// with a help line; unknown options, missing values and bad values are errors naming the option.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/result.h"
#include "core/se3.h"

namespace ef::app {

struct OptionSpec {
  std::string name;         // "--out"
  std::string value_name;   // "DIR"; empty for a flag
  std::string help;         // one line, with unit and default
  bool required = false;
};

class ParsedArgs {
 public:
  bool has(const std::string& name) const;
  // The value of an option that takes one; `fallback` when absent.
  std::string get(const std::string& name, const std::string& fallback = "") const;
  const std::vector<std::string>& positionals() const { return positionals_; }

  // Typed getters: errors name the option and the bad value.
  Result<int64_t> get_int(const std::string& name, int64_t fallback, int64_t min_value, int64_t max_value) const;
  Result<double> get_double(const std::string& name, double fallback, double min_value, double max_value) const;

 private:
  friend Result<ParsedArgs> parse_args(const std::string&, const std::vector<OptionSpec>&, int, int, char**, int);
  std::vector<std::pair<std::string, std::string>> values_;
  std::vector<std::string> positionals_;
};

// Parses argv[first..argc). `command` names the command in messages ("edgefusion run").
// positional_count: how many positional arguments are expected exactly (-1: any number).
// Callers check wants_help() before parsing.
Result<ParsedArgs> parse_args(const std::string& command, const std::vector<OptionSpec>& specs,
                              int positional_count, int argc, char** argv, int first);

// True when argv[first..argc) contains -h or --help.
bool wants_help(int argc, char** argv, int first);

// "Usage: <usage>\n\n<description>\n\nOptions:\n  --out DIR   help..." for a command.
std::string format_help(const std::string& usage, const std::string& description,
                        const std::vector<OptionSpec>& specs);

// Parses "WIDTHxHEIGHT" (e.g. "320x240"); errors name `what`.
Result<std::pair<int, int>> parse_resolution(const std::string& text, const std::string& what);

// Parses "TX TY TZ QX QY QZ QW" (camera-to-world, TUM order: metres, then a quaternion normalised
// here) into a pose; errors name `what`: not 7 numbers, a zero quaternion, or one whose norm
// overflows (a NaN rotation otherwise).
Result<SE3> parse_pose(const std::string& text, const std::string& what);

}  // namespace ef::app
