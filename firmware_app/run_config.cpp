#include "run_config.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

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
    << "progress: " << (progress ? "true" : "false") << "      # progress line on stderr; default true\n"
    << "surfel_capacity: " << surfel_capacity << "  # surfels in the map's pool (fixed at start-up); default 1000000\n"
    << "icp_weight: " << icp_weight << "          # tracking: weight of the ICP term, >= 0; default 10\n"
    << "rgb_weight: " << rgb_weight << "           # tracking: weight of the photometric term, >= 0; default 0.25\n"
    << "depth_cutoff_m: " << depth_cutoff_m << "       # metres; depths beyond are ignored; default 8\n"
    << "map: " << (write_map ? "true" : "false") << "           # write map.ply; default true\n"
    << "labels: " << (labels ? "true" : "false") << "        # CNN segmentation + label fusion; default true\n"
    << "model: " << model << "          # .efm segmentation model; default the shipped model\n"
    << "label_every: " << label_every << "      # frames between CNN label updates, >= 1; default 10\n"
    << "labels_out: " << labels_out << "     # folder for rendered class-id PNGs; default none\n"
    << "labels_out_every: " << labels_out_every << " # write every K-th frame's rendering, >= 1; default 10\n"
    << "crf_every: " << crf_every << "         # frames between dense CRF runs, 0 = off; default 0\n"
    << "crf_final: " << (crf_final ? "true" : "false") << "     # dense CRF once at the end; default false\n"
    << "crf_iterations: " << crf_iterations << "   # mean-field iterations per CRF run, 1..100; default 10\n"
    << "label_visibility: " << (label_visibility ? "true" : "false")
    << " # labels only for surfels at the measured depth; default true\n";
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
  } else if (key == "progress" || key == "map" || key == "labels" || key == "crf_final" ||
             key == "label_visibility") {
    bool v = false;
    if (value == "true" || value == "yes" || value == "on") v = true;
    else if (value == "false" || value == "no" || value == "off") v = false;
    else return bad("is not true or false");
    if (key == "map") config.write_map = v;
    else if (key == "progress") config.progress = v;
    else if (key == "labels") config.labels = v;
    else if (key == "label_visibility") config.label_visibility = v;
    else config.crf_final = v;
  } else if (key == "model" || key == "labels_out") {
    if (value.empty()) return bad(key == "model" ? "is empty (expected a .efm file)" : "is empty (expected a folder)");
    (key == "model" ? config.model : config.labels_out) = value;
  } else if (key == "label_every" || key == "labels_out_every" || key == "crf_every" || key == "crf_iterations") {
    errno = 0;
    char* end = nullptr;
    const long long v = std::strtoll(value.c_str(), &end, 10);
    const long long lo = key == "crf_every" ? 0 : 1;
    const long long hi = key == "crf_iterations" ? 100 : 1'000'000;
    if (value.empty() || *end != '\0' || errno == ERANGE || v < lo || v > hi)
      return bad("is not an integer in " + std::to_string(lo) + ".." + std::to_string(hi));
    if (key == "label_every") config.label_every = static_cast<int>(v);
    else if (key == "labels_out_every") config.labels_out_every = static_cast<int>(v);
    else if (key == "crf_every") config.crf_every = static_cast<int>(v);
    else config.crf_iterations = static_cast<int>(v);
  } else if (key == "surfel_capacity") {
    errno = 0;
    char* end = nullptr;
    const long long v = std::strtoll(value.c_str(), &end, 10);
    if (value.empty() || *end != '\0' || errno == ERANGE || v < 1 || v > 100'000'000)
      return bad("is not an integer in 1..100000000");
    config.surfel_capacity = v;
  } else if (key == "icp_weight" || key == "rgb_weight" || key == "depth_cutoff_m") {
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(value.c_str(), &end);
    if (value.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(v) || v < 0)
      return bad("is not a finite number >= 0");
    if (key == "depth_cutoff_m" && v <= 0) return bad("must be > 0 (metres)");
    if (key == "icp_weight") config.icp_weight = v;
    else if (key == "rgb_weight") config.rgb_weight = v;
    else config.depth_cutoff_m = static_cast<float>(v);
  } else {
    return error(ErrorCode::kInvalidArgument,
                 where + ": unknown key '" + key +
                     "' (known: source, resolution, frames, out, progress, map, surfel_capacity, icp_weight, "
                     "rgb_weight, depth_cutoff_m, labels, model, label_every, labels_out, labels_out_every, "
                     "crf_every, crf_final, crf_iterations, label_visibility)");
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
