#include "config_file.h"

// GCC 12 reports -Wdangling-pointer inside yaml-cpp 0.7's node/impl.h once its inline functions are
// inlined here (a false positive on the library's own temporaries, fixed in later yaml-cpp).
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ >= 12
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdangling-pointer"
#endif
#include <yaml-cpp/yaml.h>
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ >= 12
#pragma GCC diagnostic pop
#endif

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

namespace ef::app {

using namespace ef::pipeline;

namespace {

// One option of the file. `path` is its key in the sectioned file ("crf.iterations"); `flat` the
// older top-level name that still works ("crf_iterations"; empty when the path is already flat).
// `doc` is the comment describe() writes: unit, range, default.
struct OptionDoc {
  const char* path;
  const char* flat;
  const char* doc;
};

// The one list of options: parsing, describe() and config_keys() all read it.
constexpr OptionDoc kOptions[] = {
    {"source", "", "frame source URI (edgefusion run --help lists them); default synthetic:"},
    {"resolution", "", "working resolution for tracking and label fusion, WIDTHxHEIGHT pixels; default 320x240"},
    {"frames", "", "frames to process, -1 = all the source has; default -1"},
    {"out", "", "output folder, created if missing; no default: run needs it here or as --out"},
    {"progress", "", "progress line on stderr; default true"},
    {"map", "", "write map.ply at the end of the run; default true"},
    {"realtime", "", "replay a recording at its recorded speed instead of as fast as possible; default false"},
    {"mapping.surfel_capacity", "surfel_capacity",
     "surfels in the map's pool, allocated at start-up (60 bytes each), 1..100000000; default 1000000"},
    {"mapping.icp_weight", "icp_weight", "tracking: weight of the ICP term, >= 0; default 10"},
    {"mapping.rgb_weight", "rgb_weight", "tracking: weight of the photometric term, >= 0; default 0.25"},
    {"mapping.rgb_boost_condition", "rgb_boost_condition",
     "tracking: the photometric weight rises where the ICP term's condition number exceeds this, 0 (off) "
     "or > 1; default 500"},
    {"mapping.rgb_boost_max", "rgb_boost_max",
     "tracking: the most the photometric weight rises there (a factor on rgb_weight), >= 1; default 16"},
    {"mapping.constant_velocity_guess", "constant_velocity_guess",
     "tracking starts each frame from the last pose times the last motion; false = from the last pose "
     "(ElasticFusion); default true"},
    {"mapping.depth_cutoff_m", "depth_cutoff_m", "metres, > 0; depths beyond are ignored; default 8"},
    {"mapping.index_map_scale", "index_map_scale",
     "index map cells per working pixel along each axis, 1..4; 4 = ElasticFusion's, slower for the same "
     "accuracy at 320x240 (docs/results.md); default 1"},
    {"mapping.associate_at_tracked_pose", "associate_at_tracked_pose",
     "fusion associates each frame through an index map rendered at its tracked pose (ElasticFusion); "
     "false = the previous pose's, one render less per frame but duplicate surfels wherever known surface "
     "enters the view (docs/results.md); default true"},
    {"labels.enabled", "labels", "CNN segmentation + Bayesian label fusion; false = geometry only; default true"},
    {"labels.model", "model", ".efm segmentation model; default the shipped models/edgefusion-seg.efm"},
    {"labels.every", "label_every", "frames between CNN label updates, 1..1000000; default 10 (the paper's)"},
    {"labels.out", "labels_out", "folder for the map's labels rendered as class-id PNGs; default none"},
    {"labels.out_every", "labels_out_every", "write every K-th frame's rendering, 1..1000000; default 10"},
    {"labels.final_out", "labels_final_out",
     "recordings only: after the run, read the recording again and write the final map's labels in every "
     "out_every-th frame, at the estimated poses, into this folder; default none"},
    {"labels.visibility", "label_visibility",
     "fuse / render only surfels at the measured depth; false = every index-map surfel; default true"},
    {"crf.every", "crf_every", "frames between dense CRF runs over the map, 0 = off; default 0 (paper: 500)"},
    {"crf.final", "crf_final", "one dense CRF over the map at the end of the run; default false"},
    {"crf.iterations", "crf_iterations", "mean-field iterations per CRF run, 1..100; default 10"},
    {"pipeline.threads", "threads",
     "1 = front (read, resample, preprocess), CNN and mapping take turns on one thread; 2 = front + CNN "
     "beside mapping; 3 = each on its own thread; same outputs; default 2"},
    {"pipeline.prepared_slots", "", "frames in flight between front, CNN and mapping, 2..16; default 3"},
    {"pipeline.capture_slots", "",
     "live cameras: frames waiting between capture and the front stage, 2..64 (full: the oldest is dropped, "
     "counted); default 4"},
    {"pipeline.front_cpu", "", "CPU core the front stage's thread is pinned to, -1 = not pinned; default -1"},
    {"pipeline.cnn_cpu", "", "CPU core the CNN's thread (threads: 3) is pinned to, -1 = not pinned; default -1"},
    {"pipeline.mapping_cpu", "", "CPU core the mapping thread is pinned to, -1 = not pinned; default -1"},
    {"pipeline.capture_cpu", "", "CPU core a live camera's capture thread is pinned to, -1 = not pinned; default -1"},
    {"memory.budget_mb", "memory_budget_mb",
     "MB (10^6 bytes), 1..1000000: a run refuses to start when its memory plan is larger; default 256"},
    {"gpio.led_chip", "", "status LED's GPIO chip (name, /dev path, number or label); default none (no LED)"},
    {"gpio.led_line", "", "status LED's line offset on that chip, 0..1023; default 0"},
    {"gpio.led_active_low", "", "the LED lights when its pin is driven low; default false"},
    {"gpio.button_chip", "", "start/stop button's GPIO chip; default none (no button)"},
    {"gpio.button_line", "", "start/stop button's line offset, 0..1023; default 0"},
    {"gpio.button_active_low", "", "the button pulls its pin low when pressed (wired to ground); default true"},
    {"gpio.debounce_ms", "", "a button level must hold this long to count, milliseconds, 1..1000; default 30"},
    {"gpio.optional", "", "a missing chip or line is a warning and the run goes on without it; default false"},
};

constexpr const char* kSections[] = {"mapping", "labels", "crf", "pipeline", "memory", "gpio"};

bool is_section(const std::string& name) {
  for (const char* s : kSections)
    if (name == s) return true;
  return false;
}

// The option a key names (section path or flat name); nullptr when none.
const OptionDoc* find_option(const std::string& key) {
  for (const OptionDoc& o : kOptions)
    if (key == o.path || (o.flat[0] != '\0' && key == o.flat)) return &o;
  return nullptr;
}

std::string known_keys_text() {
  std::string s;
  for (const OptionDoc& o : kOptions) s += (s.empty() ? "" : ", ") + std::string(o.path);
  return s;
}

Result<long long> parse_integer(const std::string& value, long long lo, long long hi) {
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(value.c_str(), &end, 10);
  if (value.empty() || *end != '\0' || errno == ERANGE || v < lo || v > hi)
    return error(ErrorCode::kInvalidArgument, "");
  return v;
}

// The shortest decimal text that reads back (strtod) as exactly `v`.
std::string number_text(double v) {
  char buf[40];
  // Whole numbers in full ("10", "500"): the shortest %g would write "1e+01" and "5e+02".
  if (v == std::trunc(v) && std::fabs(v) < 1e15) {
    std::snprintf(buf, sizeof buf, "%.0f", v);
    return buf;
  }
  for (int precision = 1; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}
// The same for a float read as strtod then narrowed (as apply_config_value does).
std::string number_text(float v) {
  char buf[40];
  if (v == std::trunc(v) && std::fabs(v) < 1e7f) {
    std::snprintf(buf, sizeof buf, "%.0f", static_cast<double>(v));
    return buf;
  }
  for (int precision = 1; precision <= 9; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, static_cast<double>(v));
    if (static_cast<float>(std::strtod(buf, nullptr)) == v) break;
  }
  return buf;
}

// A YAML double-quoted scalar holding `s` exactly.
std::string quoted(const std::string& s) {
  std::string q = "\"";
  for (const char ch : s) {
    const auto u = static_cast<unsigned char>(ch);
    if (ch == '"' || ch == '\\') {
      q += '\\';
      q += ch;
    } else if (u < 0x20 || u == 0x7f) {
      char esc[8];
      std::snprintf(esc, sizeof esc, "\\x%02x", u);
      q += esc;
    } else {
      q += ch;
    }
  }
  return q + "\"";
}

const char* bool_text(bool b) { return b ? "true" : "false"; }

// The value of option `path` in `c` as YAML text; empty for an empty string option.
std::string value_text(const RunConfig& c, const std::string& path) {
  if (path == "source") return quoted(c.source);
  if (path == "resolution") return std::to_string(c.width) + "x" + std::to_string(c.height);
  if (path == "frames") return std::to_string(c.max_frames);
  if (path == "out") return c.out_dir.empty() ? "" : quoted(c.out_dir);
  if (path == "progress") return bool_text(c.progress);
  if (path == "map") return bool_text(c.write_map);
  if (path == "realtime") return bool_text(c.realtime);
  if (path == "mapping.surfel_capacity") return std::to_string(c.surfel_capacity);
  if (path == "mapping.icp_weight") return number_text(c.icp_weight);
  if (path == "mapping.rgb_weight") return number_text(c.rgb_weight);
  if (path == "mapping.rgb_boost_condition") return number_text(c.rgb_boost_condition);
  if (path == "mapping.rgb_boost_max") return number_text(c.rgb_boost_max);
  if (path == "mapping.constant_velocity_guess") return bool_text(c.constant_velocity_guess);
  if (path == "mapping.depth_cutoff_m") return number_text(c.depth_cutoff_m);
  if (path == "mapping.index_map_scale") return std::to_string(c.index_map_scale);
  if (path == "mapping.associate_at_tracked_pose") return bool_text(c.associate_at_tracked_pose);
  if (path == "labels.enabled") return bool_text(c.labels);
  if (path == "labels.model") return c.model.empty() ? "" : quoted(c.model);
  if (path == "labels.every") return std::to_string(c.label_every);
  if (path == "labels.out") return c.labels_out.empty() ? "" : quoted(c.labels_out);
  if (path == "labels.out_every") return std::to_string(c.labels_out_every);
  if (path == "labels.final_out") return c.labels_final_out.empty() ? "" : quoted(c.labels_final_out);
  if (path == "labels.visibility") return bool_text(c.label_visibility);
  if (path == "crf.every") return std::to_string(c.crf_every);
  if (path == "crf.final") return bool_text(c.crf_final);
  if (path == "crf.iterations") return std::to_string(c.crf_iterations);
  if (path == "pipeline.threads") return std::to_string(c.threads);
  if (path == "pipeline.prepared_slots") return std::to_string(c.prepared_slots);
  if (path == "pipeline.capture_slots") return std::to_string(c.capture_slots);
  if (path == "pipeline.front_cpu") return std::to_string(c.front_cpu);
  if (path == "pipeline.cnn_cpu") return std::to_string(c.cnn_cpu);
  if (path == "pipeline.mapping_cpu") return std::to_string(c.mapping_cpu);
  if (path == "pipeline.capture_cpu") return std::to_string(c.capture_cpu);
  if (path == "memory.budget_mb") return std::to_string(c.memory_budget_mb);
  if (path == "gpio.led_chip") return c.gpio.led.chip.empty() ? "" : quoted(c.gpio.led.chip);
  if (path == "gpio.led_line") return std::to_string(c.gpio.led.offset);
  if (path == "gpio.led_active_low") return bool_text(c.gpio.led.active_low);
  if (path == "gpio.button_chip") return c.gpio.button.chip.empty() ? "" : quoted(c.gpio.button.chip);
  if (path == "gpio.button_line") return std::to_string(c.gpio.button.offset);
  if (path == "gpio.button_active_low") return bool_text(c.gpio.button.active_low);
  if (path == "gpio.debounce_ms") return std::to_string(c.gpio.debounce_ms);
  if (path == "gpio.optional") return bool_text(c.gpio.optional);
  return "";
}

// YAML reads `key: synthetic:` as a nested key and rejects it ("illegal map value"). A source URI
// often ends in ':' (synthetic:, openni2:), so on a block `key: value` line whose value is a single
// plain word ending in ':' the word is put in double quotes. Such a line is never valid YAML as
// written, so no valid document changes meaning; line numbers are kept.
std::string quote_trailing_colon_values(const std::string& text) {
  std::string out;
  out.reserve(text.size() + 16);
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    std::string line = text.substr(pos, eol - pos);
    pos = eol + 1;
    const bool had_newline = eol < text.size();

    std::size_t i = line.find_first_not_of(" \t");
    const std::size_t key_begin = i;
    while (i < line.size() && (std::isalnum(static_cast<unsigned char>(line[i])) || line[i] == '_' ||
                               line[i] == '.' || line[i] == '-'))
      ++i;
    const bool key_ok = key_begin != std::string::npos && i > key_begin && i + 1 < line.size() && line[i] == ':' &&
                        (line[i + 1] == ' ' || line[i + 1] == '\t');
    if (key_ok) {
      const std::size_t v_begin = line.find_first_not_of(" \t", i + 1);
      if (v_begin != std::string::npos && std::string("\"'{[&*!|>#%@`").find(line[v_begin]) == std::string::npos) {
        std::size_t v_end = line.find_first_of(" \t\r", v_begin);
        if (v_end == std::string::npos) v_end = line.size();
        const std::size_t rest = line.find_first_not_of(" \t\r", v_end);
        const bool only_comment_after = rest == std::string::npos || line[rest] == '#';
        if (only_comment_after && line[v_end - 1] == ':')
          line = line.substr(0, v_begin) + quoted(line.substr(v_begin, v_end - v_begin)) + line.substr(v_end);
      }
    }
    out += line;
    if (had_newline) out += '\n';
  }
  return out;
}

std::string node_kind(const YAML::Node& n) {
  if (n.IsSequence()) return "a list";
  if (n.IsMap()) return "a section of keys";
  return "a value";
}

// Reads the options of one mapping node (the top level, or a section with `prefix`).
class FileReader {
 public:
  FileReader(std::string name, RunConfig& config) : name_(std::move(name)), config_(config) {}

  std::string where(const YAML::Mark& m) const {
    return "configuration file '" + name_ + "' line " + std::to_string(m.line + 1);
  }

  Status read_map(const YAML::Node& map, const std::string& prefix) {
    for (const auto& kv : map) {  // kv: a pair of Nodes by value (yaml-cpp's iterator yields proxies)
      const YAML::Node k = kv.first;
      const YAML::Node v = kv.second;
      const std::string at = where(k.Mark());
      if (!k.IsScalar())
        return error(ErrorCode::kInvalidArgument, at + ": a key must be a plain name, got " + node_kind(k));
      const std::string key = prefix.empty() ? k.Scalar() : prefix + "." + k.Scalar();
      if (prefix.empty() && is_section(key) && (v.IsMap() || key != "labels")) {
        // A section (`labels: true` is also the flat switch of labels.enabled).
        if (!v.IsMap())
          return error(ErrorCode::kInvalidArgument,
                       at + ": key '" + key + "': expected a section of keys (for example " + key +
                           ": {key: value} or indented lines below it), got " +
                           (v.IsScalar() ? "'" + v.Scalar() + "'" : node_kind(v)));
        EF_RETURN_IF_ERROR(read_map(v, key));
        continue;
      }
      const OptionDoc* opt = find_option(key);
      if (opt == nullptr)
        return error(ErrorCode::kInvalidArgument,
                     at + ": unknown key '" + key + "' (known: " + known_keys_text() +
                         "; flat names such as surfel_capacity also work at the top level)");
      if (v.IsMap() || v.IsSequence())
        return error(ErrorCode::kInvalidArgument, at + ": key '" + key + "': expected one value, got " + node_kind(v));
      const auto seen = seen_.find(opt->path);
      if (seen != seen_.end())
        return error(ErrorCode::kInvalidArgument, at + ": key '" + key + "' sets " + opt->path +
                                                      ", which line " + std::to_string(seen->second) +
                                                      " already set");
      seen_[opt->path] = k.Mark().line + 1;
      const std::string value = v.IsNull() ? "" : v.Scalar();
      EF_RETURN_IF_ERROR(apply_config_value(key, value, at, config_));
    }
    return Status::success();
  }

 private:
  std::string name_;
  RunConfig& config_;
  std::map<std::string, int> seen_;  // option path -> line that set it
};

}  // namespace

std::string describe_config(const RunConfig& config) {
  std::ostringstream o;
  o << "# edgefusion configuration (YAML): every option with its unit, range and default.\n"
       "# Flat names (surfel_capacity, label_every, crf_iterations, ...) also work at the top level.\n";
  std::string section;
  for (const OptionDoc& opt : kOptions) {
    const std::string path = opt.path;
    const auto dot = path.find('.');
    const std::string sec = dot == std::string::npos ? "" : path.substr(0, dot);
    const std::string name = dot == std::string::npos ? path : path.substr(dot + 1);
    if (sec != section) {
      o << sec << ":\n";
      section = sec;
    }
    const std::string value = value_text(config, path);
    std::string line = (sec.empty() ? "" : "  ") + std::string(value.empty() ? "# " : "") + name + ":" +
                       (value.empty() ? "" : " " + value);
    if (line.size() < 34) line.resize(34, ' ');
    o << line << " # " << opt.doc << "\n";
  }
  return o.str();
}

std::vector<std::string> config_keys() {
  std::vector<std::string> keys;
  for (const OptionDoc& o : kOptions) keys.emplace_back(o.path);
  return keys;
}

Status apply_config_value(const std::string& key, const std::string& value, const std::string& where,
                          RunConfig& config) {
  const auto bad = [&](const std::string& why) {
    return error(ErrorCode::kInvalidArgument, where + ": key '" + key + "': '" + value + "' " + why);
  };
  const OptionDoc* opt = find_option(key);
  if (opt == nullptr)
    return error(ErrorCode::kInvalidArgument, where + ": unknown key '" + key + "' (known: " + known_keys_text() + ")");
  const std::string path = opt->path;

  if (path == "source") {
    if (value.empty()) return bad("is empty (expected a source URI)");
    config.source = value;
  } else if (path == "resolution") {
    auto r = parse_resolution(value, where + ": key '" + key + "'");
    if (!r.ok()) return r.take_error();
    config.width = r->first;
    config.height = r->second;
  } else if (path == "frames") {
    auto v = parse_integer(value, -1, INT64_MAX);
    if (!v.ok() || *v == 0) return bad("is not a positive integer or -1");
    config.max_frames = *v;
  } else if (path == "out" || path == "labels.model" || path == "labels.out" || path == "labels.final_out") {
    if (value.empty()) return bad(path == "labels.model" ? "is empty (expected a .efm file)" : "is empty (expected a folder)");
    (path == "out"            ? config.out_dir
     : path == "labels.model" ? config.model
     : path == "labels.out"   ? config.labels_out
                              : config.labels_final_out) = value;
  } else if (path == "gpio.led_chip" || path == "gpio.button_chip") {
    if (value.empty()) return bad("is empty (expected a chip name, /dev path, number or label)");
    (path == "gpio.led_chip" ? config.gpio.led.chip : config.gpio.button.chip) = value;
  } else if (path == "gpio.led_line" || path == "gpio.button_line" || path == "gpio.debounce_ms") {
    const bool lines = path != "gpio.debounce_ms";
    auto v = parse_integer(value, lines ? 0 : 1, lines ? 1023 : 1000);
    if (!v.ok()) return bad(lines ? "is not a line offset in 0..1023" : "is not an integer in 1..1000 (ms)");
    if (path == "gpio.led_line") config.gpio.led.offset = static_cast<unsigned>(*v);
    else if (path == "gpio.button_line") config.gpio.button.offset = static_cast<unsigned>(*v);
    else config.gpio.debounce_ms = static_cast<int>(*v);
  } else if (path == "progress" || path == "map" || path == "realtime" || path == "labels.enabled" ||
             path == "labels.visibility" || path == "mapping.associate_at_tracked_pose" ||
             path == "mapping.constant_velocity_guess" || path == "crf.final" || path == "gpio.led_active_low" ||
             path == "gpio.button_active_low" || path == "gpio.optional") {
    bool v = false;
    if (value == "true" || value == "True" || value == "TRUE" || value == "yes" || value == "on") v = true;
    else if (value == "false" || value == "False" || value == "FALSE" || value == "no" || value == "off") v = false;
    else return bad("is not true or false");
    if (path == "progress") config.progress = v;
    else if (path == "map") config.write_map = v;
    else if (path == "realtime") config.realtime = v;
    else if (path == "labels.enabled") config.labels = v;
    else if (path == "labels.visibility") config.label_visibility = v;
    else if (path == "mapping.associate_at_tracked_pose") config.associate_at_tracked_pose = v;
    else if (path == "mapping.constant_velocity_guess") config.constant_velocity_guess = v;
    else if (path == "gpio.led_active_low") config.gpio.led.active_low = v;
    else if (path == "gpio.button_active_low") config.gpio.button.active_low = v;
    else if (path == "gpio.optional") config.gpio.optional = v;
    else config.crf_final = v;
  } else if (path == "labels.every" || path == "labels.out_every" || path == "crf.every" || path == "crf.iterations") {
    const long long lo = path == "crf.every" ? 0 : 1;
    const long long hi = path == "crf.iterations" ? 100 : 1'000'000;
    auto v = parse_integer(value, lo, hi);
    if (!v.ok()) return bad("is not an integer in " + std::to_string(lo) + ".." + std::to_string(hi));
    const int n = static_cast<int>(*v);
    if (path == "labels.every") config.label_every = n;
    else if (path == "labels.out_every") config.labels_out_every = n;
    else if (path == "crf.every") config.crf_every = n;
    else config.crf_iterations = n;
  } else if (path == "mapping.surfel_capacity") {
    auto v = parse_integer(value, 1, 100'000'000);
    if (!v.ok()) return bad("is not an integer in 1..100000000");
    config.surfel_capacity = *v;
  } else if (path == "mapping.index_map_scale") {
    auto v = parse_integer(value, 1, 4);
    if (!v.ok()) return bad("is not an integer in 1..4 (index map cells per working pixel, each axis)");
    config.index_map_scale = static_cast<int>(*v);
  } else if (path.rfind("pipeline.", 0) == 0) {
    const bool cpu = path.size() > 4 && path.compare(path.size() - 4, 4, "_cpu") == 0;
    const long long lo = cpu ? -1 : path == "pipeline.threads" ? 1 : 2;
    const long long hi = cpu ? 1023 : path == "pipeline.threads" ? 3 : path == "pipeline.prepared_slots" ? 16 : 64;
    auto v = parse_integer(value, lo, hi);
    if (!v.ok())
      return bad("is not an integer in " + std::to_string(lo) + ".." + std::to_string(hi) +
                 (cpu ? " (a CPU core, -1 = not pinned)" : ""));
    const int n = static_cast<int>(*v);
    if (path == "pipeline.threads") config.threads = n;
    else if (path == "pipeline.prepared_slots") config.prepared_slots = n;
    else if (path == "pipeline.capture_slots") config.capture_slots = n;
    else if (path == "pipeline.front_cpu") config.front_cpu = n;
    else if (path == "pipeline.cnn_cpu") config.cnn_cpu = n;
    else if (path == "pipeline.mapping_cpu") config.mapping_cpu = n;
    else config.capture_cpu = n;
  } else if (path == "memory.budget_mb") {
    auto v = parse_integer(value, 1, 1'000'000);
    if (!v.ok()) return bad("is not an integer in 1..1000000 (MB)");
    config.memory_budget_mb = *v;
  } else {  // mapping.icp_weight, rgb_weight, rgb_boost_condition, rgb_boost_max, depth_cutoff_m
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(value.c_str(), &end);
    if (value.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(v) || v < 0)
      return bad("is not a finite number >= 0");
    if (path == "mapping.depth_cutoff_m" && v <= 0) return bad("must be > 0 (metres)");
    if (path == "mapping.rgb_boost_condition" && v > 0 && v <= 1) return bad("must be 0 (off) or > 1");
    if (path == "mapping.rgb_boost_max" && v < 1) return bad("must be >= 1 (a factor)");
    if (path == "mapping.icp_weight") config.icp_weight = v;
    else if (path == "mapping.rgb_weight") config.rgb_weight = v;
    else if (path == "mapping.rgb_boost_condition") config.rgb_boost_condition = v;
    else if (path == "mapping.rgb_boost_max") config.rgb_boost_max = v;
    else config.depth_cutoff_m = static_cast<float>(v);
  }
  return Status::success();
}

Status apply_config_text(const std::string& text, const std::string& name, RunConfig& config) {
  YAML::Node root;
  try {
    root = YAML::Load(quote_trailing_colon_values(text));
  } catch (const YAML::Exception& e) {
    return error(ErrorCode::kInvalidArgument, "configuration file '" + name + "' line " +
                                                  std::to_string(e.mark.line + 1) + " column " +
                                                  std::to_string(e.mark.column + 1) + ": YAML syntax error: " + e.msg);
  }
  if (root.IsNull()) return Status::success();  // empty, or only comments
  if (!root.IsMap())
    return error(ErrorCode::kInvalidArgument, "configuration file '" + name + "' line " +
                                                  std::to_string(root.Mark().line + 1) +
                                                  ": expected 'key: value' lines, got " + node_kind(root));
  // A copy, so that a file with an error leaves `config` as it was.
  RunConfig updated = config;
  FileReader reader(name, updated);
  try {
    EF_RETURN_IF_ERROR(reader.read_map(root, ""));
  } catch (const YAML::Exception& e) {  // not expected once loaded; kept so no exception escapes
    return error(ErrorCode::kInvalidArgument, "configuration file '" + name + "': " + e.what());
  }
  config = updated;
  return Status::success();
}

Status apply_config_file(const std::string& path, RunConfig& config) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return error(ErrorCode::kNotFound, "configuration file '" + path + "': cannot open");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return error(ErrorCode::kIoError, "configuration file '" + path + "': read error");
  return apply_config_text(text.str(), path, config);
}

const std::vector<OptionSpec>& config_override_options() {
  static const std::vector<OptionSpec> specs = {
      {"--config", "FILE", "YAML configuration file (edgefusion plan --help prints every key)"},
      {"--source", "URI", "frame source; default synthetic:"},
      {"--resolution", "WxH", "working resolution for tracking and label fusion, pixels; default 320x240"},
      {"--frames", "N", "process at most N frames; default all the source has"},
      {"--out", "DIR", "output folder, created if missing"},
      {"--quiet", "", "no progress line"},
      {"--realtime", "", "replay a recording at its recorded speed (timestamps); default as fast as possible"},
      {"--surfel-capacity", "N", "surfels in the map's pool (60 bytes each); default 1000000"},
      {"--model", "FILE", "segmentation model (.efm); default the shipped model"},
      {"--no-labels", "", "geometry only: no CNN, no label fusion, no class in map.ply"},
      {"--label-every", "N", "segment and fuse labels every N-th frame; default 10 (the paper's)"},
      {"--labels-out", "DIR", "write the map's labels rendered into every K-th frame as DIR/<frame>.png"},
      {"--labels-out-every", "K", "with --labels-out: every K-th frame, counted from the first; default 10"},
      {"--labels-final-out", "DIR",
       "recordings: after the run, the final map's labels in every K-th frame (at the estimated poses) as "
       "DIR/<frame>.png"},
      {"--crf-every", "M", "dense CRF over the whole map every M frames; default 0 = off (paper: 500)"},
      {"--crf-final", "", "dense CRF over the whole map once at the end, before map.ply is written"},
      {"--crf-iterations", "N", "mean-field iterations per CRF run, 1..100; default 10"},
      {"--memory-budget-mb", "MB", "refuse to start when the memory plan exceeds this, MB; default 256"},
      {"--threads", "N", "1 = every step on one thread; 2 = front + CNN beside mapping; 3 = each its own; default 2"},
  };
  return specs;
}

Result<RunConfig> config_from_args(const ParsedArgs& args) {
  RunConfig config;
  if (args.has("--config")) EF_RETURN_IF_ERROR(apply_config_file(args.get("--config"), config));
  // Option --x-y overrides the flat key x_y.
  for (const char* key : {"source", "resolution", "frames", "out", "surfel_capacity", "model", "label_every",
                          "labels_out", "labels_out_every", "labels_final_out", "crf_every", "crf_iterations", "memory_budget_mb",
                          "threads"}) {
    std::string opt = std::string("--") + key;
    for (char& ch : opt)
      if (ch == '_') ch = '-';
    if (!args.has(opt)) continue;
    EF_RETURN_IF_ERROR(apply_config_value(key, args.get(opt), "option " + opt, config));
  }
  if (args.has("--quiet")) config.progress = false;
  if (args.has("--realtime")) config.realtime = true;
  if (args.has("--no-labels")) config.labels = false;
  if (args.has("--crf-final")) config.crf_final = true;
  return config;
}

}  // namespace ef::app
