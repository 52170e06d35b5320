// libFuzzer target for the YAML configuration of `run` and `plan` (firmware_app/config_file.h over
// yaml-cpp, the keys of pipeline/run_config.h and their value parsers in core/options.h). Input: the
// file's text. A text that applies is validated as `run` does (against a fixed set of cores, so the
// outcome does not depend on the machine), and must survive the round trip the configuration
// promises: describe() of it, read back into a fresh configuration, describes the same again (a
// difference aborts: a finding). Any crash, sanitizer report, uncaught exception or hang is a bug.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "firmware_app/config_file.h"
#include "pipeline/run_config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  ef::pipeline::RunConfig config;
  if (!ef::app::apply_config_text(text, "fuzz.yaml", config).ok()) return 0;
  (void)config.validate({0, 1, 2, 3});
  if (config.labels.enabled && config.crf.on()) (void)ef::pipeline::crf_options_for_run(config);
  const std::string described = config.describe();
  ef::pipeline::RunConfig again;
  const ef::Status read_back = ef::app::apply_config_text(described, "described.yaml", again);
  if (!read_back.ok()) {
    std::fprintf(stderr, "describe() wrote a file that does not read back: %s\n--- input\n%s\n--- described\n%s\n",
                 ef::to_string(read_back.error()).c_str(), text.c_str(), described.c_str());
    std::abort();
  }
  if (again.describe() != described) {
    std::fprintf(stderr, "describe() of the configuration read back differs\n--- input\n%s\n--- described\n%s\n--- again\n%s\n",
                 text.c_str(), described.c_str(), again.describe().c_str());
    std::abort();
  }
  return 0;
}
