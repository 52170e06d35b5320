#include "run_config.h"

#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "args.h"

namespace ef::app {

namespace {
std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

std::string unquote(const std::string& s) {
  if (s.size() >= 2 && ((s.front() == '"' && s.back() == '"') || (s.front() == '\'' && s.back() == '\'')))
    return s.substr(1, s.size() - 2);
  return s;
}
}  // namespace

std::string RunConfig::describe() const {
  std::ostringstream o;
  o << "source: " << source << "        # source URI; default synthetic:\n"
    << "resolution: " << width << "x" << height << "   # working resolution, pixels; default 320x240\n"
    << "frames: " << max_frames << "           # frames to process, -1 = all; default -1\n"
    << "out: " << out_dir << "          # output folder; no default\n"
    << "progress: " << (progress ? "true" : "false") << "      # progress line on stderr; default true\n";
  return o.str();
}

Status apply_config_value(const std::string& key, const std::string& value, const std::string& where,
                          RunConfig& config) {
  const auto bad = [&](const std::string& why) {
    return error(ErrorCode::kInvalidArgument, where + ": key '" + key + "': '" + value + "' " + why);
  };
  if (key == "source") {
    if (value.empty()) return bad("is empty (expected a source URI)");
    config.source = value;
  } else if (key == "resolution") {
    auto r = parse_resolution(value, where + ": key 'resolution'");
    if (!r.ok()) return r.take_error();
    config.width = r->first;
    config.height = r->second;
  } else if (key == "frames") {
    errno = 0;
    char* end = nullptr;
    const long long v = std::strtoll(value.c_str(), &end, 10);
    if (value.empty() || *end != '\0' || errno == ERANGE || (v < 1 && v != -1))
      return bad("is not a positive integer or -1");
    config.max_frames = v;
  } else if (key == "out") {
    if (value.empty()) return bad("is empty (expected a folder)");
    config.out_dir = value;
  } else if (key == "progress") {
    if (value == "true" || value == "yes" || value == "on") config.progress = true;
    else if (value == "false" || value == "no" || value == "off") config.progress = false;
    else return bad("is not true or false");
  } else {
    return error(ErrorCode::kInvalidArgument,
                 where + ": unknown key '" + key + "' (known: source, resolution, frames, out, progress)");
  }
  return Status::success();
}

Status apply_config_file(const std::string& path, RunConfig& config) {
  std::ifstream in(path);
  if (!in) return error(ErrorCode::kNotFound, "configuration file '" + path + "': cannot open");
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string where = "configuration file '" + path + "' line " + std::to_string(line_no);
    // Strip a comment: '#' at the start or after whitespace (a URI may hold '#'-free text only).
    for (std::size_t i = 0; i < line.size(); ++i) {
      if (line[i] == '#' && (i == 0 || line[i - 1] == ' ' || line[i - 1] == '\t')) {
        line.resize(i);
        break;
      }
    }
    const std::string t = trim(line);
    if (t.empty() || t == "---") continue;
    const auto colon = t.find(':');
    // A value may itself hold ':' (a URI), so split at the first ": " or a trailing ':'.
    const auto sep = t.find(": ");
    const auto split = sep != std::string::npos ? sep : (colon == t.size() - 1 ? colon : std::string::npos);
    if (split == std::string::npos || split == 0)
      return error(ErrorCode::kInvalidArgument, where + ": expected 'key: value', got '" + t + "'");
    const std::string key = trim(t.substr(0, split));
    const std::string value = unquote(trim(t.substr(split + 1)));
    EF_RETURN_IF_ERROR(apply_config_value(key, value, where, config));
  }
  return Status::success();
}

}  // namespace ef::app
