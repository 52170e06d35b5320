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
#include <fstream>
#include <map>
#include <sstream>
#include <string>

namespace ef::app {

using namespace ef::pipeline;

namespace {

std::string known_keys_text() {
  std::string s;
  for (const ConfigKey& k : config_keys()) s += (s.empty() ? "" : ", ") + k.path;
  return s;
}

bool is_section(const std::string& name) {
  for (const std::string& s : config_sections())
    if (name == s) return true;
  return false;
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
          line = line.substr(0, v_begin) + opt::yaml_quoted(line.substr(v_begin, v_end - v_begin)) + line.substr(v_end);
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
      if (prefix.empty() && is_section(key) && (v.IsMap() || find_config_key(key) == nullptr)) {
        // A section; a section's name that is also a flat key takes a value (`labels: true`, the
        // flat switch of labels.enabled).
        if (!v.IsMap())
          return error(ErrorCode::kInvalidArgument,
                       at + ": key '" + key + "': expected a section of keys (for example " + key +
                           ": {key: value} or indented lines below it), got " +
                           (v.IsScalar() ? "'" + v.Scalar() + "'" : node_kind(v)));
        EF_RETURN_IF_ERROR(read_map(v, key));
        continue;
      }
      const ConfigKey* option = find_config_key(key);
      if (option == nullptr)
        return error(ErrorCode::kInvalidArgument,
                     at + ": unknown key '" + key + "' (known: " + known_keys_text() +
                         "; flat names such as surfel_capacity also work at the top level)");
      if (v.IsMap() || v.IsSequence())
        return error(ErrorCode::kInvalidArgument, at + ": key '" + key + "': expected one value, got " + node_kind(v));
      const auto seen = seen_.find(option->path);
      if (seen != seen_.end())
        return error(ErrorCode::kInvalidArgument, at + ": key '" + key + "' sets " + option->path +
                                                      ", which line " + std::to_string(seen->second) +
                                                      " already set");
      seen_[option->path] = k.Mark().line + 1;
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

Status apply_config_value(const std::string& key, const std::string& value, const std::string& where,
                          RunConfig& config) {
  const ConfigKey* option = find_config_key(key);
  if (option == nullptr)
    return error(ErrorCode::kInvalidArgument, where + ": unknown key '" + key + "' (known: " + known_keys_text() + ")");
  const std::string why = option->parse(config, value);
  if (!why.empty()) return error(ErrorCode::kInvalidArgument, where + ": key '" + key + "': '" + value + "' " + why);
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
  static const std::vector<OptionSpec> specs = [] {
    std::vector<OptionSpec> s = {
        {"--config", "FILE", "YAML configuration file (edgefusion plan --help prints every key)"}};
    for (const ConfigKey& k : config_keys()) {
      if (k.flag.empty()) continue;
      const bool is_flag = k.kind == opt::Value::kBool;
      // A bool's flag sets the opposite of its default: say what it does, not the key's wording.
      std::string help = is_flag ? k.path + ": " + (k.get(RunConfig()).b ? "false" : "true") + " (" + k.help + ")"
                                 : k.doc();
      std::string value_name;
      if (!is_flag) {
        value_name = k.kind == opt::Value::kText   ? (k.unit.find("folder") != std::string::npos ? "DIR"
                                                      : k.unit.find("URI") != std::string::npos  ? "URI"
                                                                                                  : "FILE")
                     : k.kind == opt::Value::kSize ? "WxH"
                                                   : "N";
      }
      s.push_back({k.flag, value_name, help});
    }
    return s;
  }();
  return specs;
}

Result<RunConfig> config_from_args(const ParsedArgs& args) {
  return config_from_args(args, args.has("--config") ? args.get("--config") : std::string());
}

Result<RunConfig> config_from_args(const ParsedArgs& args, const std::string& base_file) {
  RunConfig config;
  if (!base_file.empty()) EF_RETURN_IF_ERROR(apply_config_file(base_file, config));
  // Every flag overrides its key, in the order of the keys.
  for (const ConfigKey& k : config_keys()) {
    if (k.flag.empty() || !args.has(k.flag)) continue;
    if (k.set_flag) {
      k.set_flag(config);
      continue;
    }
    EF_RETURN_IF_ERROR(apply_config_value(k.path, args.get(k.flag), "option " + k.flag, config));
  }
  return config;
}

}  // namespace ef::app
