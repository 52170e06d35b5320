// libFuzzer target for the command line (firmware_app/args.h): every command's option table as its
// parse_args() takes it (commands.h command_syntaxes()), the typed values (integers, numbers, WxH,
// poses, ISA names), and for run and plan the configuration the flags build (config_file.h
// config_from_args: every key's flag and value parser) with its validate(). Nothing is run: the
// commands' work starts after this, and --config FILE is not read (fuzz_config covers the file).
// Input: byte 0 picks the command, the rest is its arguments separated by NUL bytes (at most 64).
// Any crash, sanitizer report, uncaught exception or hang is a bug; an error is the expected answer.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "firmware_app/args.h"
#include "firmware_app/commands.h"
#include "firmware_app/config_file.h"
#include "semantic/segmenter.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const auto& syntaxes = ef::app::command_syntaxes();
  const ef::app::CommandSyntax& cmd = syntaxes[data[0] % syntaxes.size()];
  // argv: "edgefusion", the command's words, then the fuzzer's arguments.
  std::vector<std::string> words = {"edgefusion"};
  for (const char* w = cmd.words; *w != '\0';) {
    const char* space = std::strchr(w, ' ');
    const std::size_t n = space != nullptr ? static_cast<std::size_t>(space - w) : std::strlen(w);
    words.emplace_back(w, n);
    w += n + (space != nullptr ? 1 : 0);
  }
  const std::string rest(reinterpret_cast<const char*>(data + 1), size - 1);
  for (std::size_t at = 0; at <= rest.size() && words.size() < 64 + 3;) {
    const std::size_t end = std::min(rest.find('\0', at), rest.size());
    words.push_back(rest.substr(at, end - at));
    at = end + 1;
  }
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(w.data());
  argv.push_back(nullptr);
  const int argc = static_cast<int>(words.size());

  if (ef::app::wants_help(argc, argv.data(), cmd.first)) (void)ef::app::format_help(cmd.words, "", cmd.options());
  auto args = ef::app::parse_args(std::string("edgefusion ") + cmd.words, cmd.options(), cmd.positionals, argc,
                                  argv.data(), cmd.first);
  if (!args.ok()) return 0;
  for (const ef::app::OptionSpec& o : cmd.options()) {
    if (o.value_name.empty() || !args->has(o.name)) continue;
    const std::string& kind = o.value_name;
    if (kind == "N" || kind == "K" || kind == "Q") {
      (void)args->get_int(o.name, 0, std::numeric_limits<int64_t>::min(), std::numeric_limits<int64_t>::max());
      (void)args->get_int(o.name, 1, 1, 1000000);
    } else if (kind == "S" || kind == "SECONDS") {
      (void)args->get_double(o.name, 0, 0.0, 10.0);
    } else if (kind == "WxH") {
      (void)ef::app::parse_resolution(args->get(o.name), o.name);
    } else if (kind.rfind("\"TX", 0) == 0) {  // view --pose "TX TY TZ QX QY QZ QW"
      (void)ef::app::parse_pose(args->get(o.name), o.name);
    } else if (kind == "NAME") {
      (void)ef::semantic::parse_isa(args->get(o.name), o.name);
    }
  }
  if (cmd.takes_config) {
    auto config = ef::app::config_from_args(*args, std::string());
    if (config.ok()) (void)config->validate({0, 1, 2, 3});
  }
  return 0;
}
