#include "args.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <sstream>

namespace ef::app {

bool ParsedArgs::has(const std::string& name) const {
  for (const auto& kv : values_)
    if (kv.first == name) return true;
  return false;
}

std::string ParsedArgs::get(const std::string& name, const std::string& fallback) const {
  for (const auto& kv : values_)
    if (kv.first == name) return kv.second;
  return fallback;
}

Result<int64_t> ParsedArgs::get_int(const std::string& name, int64_t fallback, int64_t min_value,
                                    int64_t max_value) const {
  if (!has(name)) return fallback;
  const std::string text = get(name);
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno == ERANGE)
    return error(ErrorCode::kInvalidArgument, name + ": '" + text + "' is not an integer");
  if (v < min_value || v > max_value)
    return error(ErrorCode::kInvalidArgument, name + ": " + text + " is outside [" + std::to_string(min_value) +
                                                  ", " + std::to_string(max_value) + "]");
  return static_cast<int64_t>(v);
}

Result<double> ParsedArgs::get_double(const std::string& name, double fallback, double min_value,
                                      double max_value) const {
  if (!has(name)) return fallback;
  const std::string text = get(name);
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(v))
    return error(ErrorCode::kInvalidArgument, name + ": '" + text + "' is not a number");
  if (v < min_value || v > max_value)
    return error(ErrorCode::kInvalidArgument, name + ": " + text + " is outside [" + std::to_string(min_value) +
                                                  ", " + std::to_string(max_value) + "]");
  return v;
}

bool wants_help(int argc, char** argv, int first) {
  for (int i = first; i < argc; ++i)
    if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0) return true;
  return false;
}

Result<ParsedArgs> parse_args(const std::string& command, const std::vector<OptionSpec>& specs,
                              int positional_count, int argc, char** argv, int first) {
  ParsedArgs out;
  // The caller reports errors prefixed with the command's name (report_error): the messages name the
  // option only, and point at the command's help.
  const std::string help = " (see " + command + " --help)";
  for (int i = first; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg.size() > 2 && arg.compare(0, 2, "--") == 0) {
      std::string value;
      bool inline_value = false;
      if (const auto eq = arg.find('='); eq != std::string::npos) {  // --out=DIR
        value = arg.substr(eq + 1);
        arg = arg.substr(0, eq);
        inline_value = true;
      }
      const OptionSpec* spec = nullptr;
      for (const auto& s : specs)
        if (s.name == arg) spec = &s;
      if (!spec) return error(ErrorCode::kInvalidArgument, "unknown option '" + arg + "'" + help);
      if (out.has(arg)) return error(ErrorCode::kInvalidArgument, "option '" + arg + "' given twice");
      if (spec->value_name.empty()) {
        if (inline_value) return error(ErrorCode::kInvalidArgument, "option '" + arg + "' takes no value");
      } else if (!inline_value) {
        if (i + 1 >= argc)
          return error(ErrorCode::kInvalidArgument, "option '" + arg + "' needs a value " + spec->value_name);
        value = argv[++i];
      }
      out.values_.emplace_back(arg, value);
    } else if (arg.size() > 1 && arg[0] == '-' && !(arg[1] >= '0' && arg[1] <= '9')) {
      return error(ErrorCode::kInvalidArgument, "unknown option '" + arg + "'" + help);
    } else {
      out.positionals_.push_back(arg);
    }
  }
  for (const auto& s : specs)
    if (s.required && !out.has(s.name))
      return error(ErrorCode::kInvalidArgument, "missing required option " + s.name + " " + s.value_name + help);
  if (positional_count >= 0 && static_cast<int>(out.positionals_.size()) != positional_count) {
    const auto count = [](std::size_t n) { return std::to_string(n) + (n == 1 ? " argument" : " arguments"); };
    return error(ErrorCode::kInvalidArgument, "expected " + count(static_cast<std::size_t>(positional_count)) +
                                                  ", got " + std::to_string(out.positionals_.size()) + help);
  }
  return out;
}

std::string format_help(const std::string& usage, const std::string& description,
                        const std::vector<OptionSpec>& specs) {
  std::string s = "Usage: " + usage + "\n\n" + description + "\n";
  if (!specs.empty()) s += "\nOptions:\n";
  std::size_t width = 0;
  for (const auto& o : specs) width = std::max(width, o.name.size() + 1 + o.value_name.size());
  for (const auto& o : specs) {
    std::string left = o.name + (o.value_name.empty() ? "" : " " + o.value_name);
    s += "  " + left + std::string(width - left.size() + 3, ' ') + o.help + (o.required ? " (required)" : "") + "\n";
  }
  s += "  -h, --help" + std::string(width > 10 ? width - 10 + 3 : 3, ' ') + "show this help\n";
  return s;
}

Result<std::pair<int, int>> parse_resolution(const std::string& text, const std::string& what) {
  const auto x = text.find('x');
  const auto bad = [&] {
    return error(ErrorCode::kInvalidArgument, what + ": '" + text + "' is not WIDTHxHEIGHT (for example 320x240)");
  };
  if (x == std::string::npos || x == 0 || x + 1 >= text.size()) return bad();
  char* end = nullptr;
  const long w = std::strtol(text.c_str(), &end, 10);
  if (end != text.c_str() + x) return bad();
  const long h = std::strtol(text.c_str() + x + 1, &end, 10);
  if (*end != '\0') return bad();
  if (w < 8 || h < 8 || w > 8192 || h > 8192)
    return error(ErrorCode::kInvalidArgument, what + ": " + text + " is outside 8x8 .. 8192x8192");
  return std::make_pair(static_cast<int>(w), static_cast<int>(h));
}

Result<SE3> parse_pose(const std::string& text, const std::string& what) {
  std::istringstream s(text);
  double v[7];
  std::string extra;
  for (double& d : v)
    if (!(s >> d)) return error(ErrorCode::kInvalidArgument, what + " needs 7 numbers: TX TY TZ QX QY QZ QW");
  if (s >> extra) return error(ErrorCode::kInvalidArgument, what + " needs 7 numbers: TX TY TZ QX QY QZ QW");
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  const double norm = q.norm();
  if (!(norm > 1e-9)) return error(ErrorCode::kInvalidArgument, what + ": the quaternion is zero");
  if (!std::isfinite(norm))
    return error(ErrorCode::kInvalidArgument, what + ": the quaternion is too large to normalise (its norm overflows)");
  return SE3(q, Eigen::Vector3d(v[0], v[1], v[2]));
}

}  // namespace ef::app
