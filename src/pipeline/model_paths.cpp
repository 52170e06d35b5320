#include "pipeline/model_paths.h"

#include <cstdlib>
#include <filesystem>

#ifndef EF_MODELS_DIR
#error "EF_MODELS_DIR must be defined (src/CMakeLists.txt): the models/ folder of the source tree"
#endif

namespace ef::pipeline {

namespace {

std::string env_or_empty(const char* name) {
  const char* v = std::getenv(name);
  return v && *v ? std::string(v) : std::string();
}

}  // namespace

std::string this_program_path() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : exe.string();
}

std::string installed_models_dir(const std::string& exe) {
  if (exe.empty()) return {};
  const std::filesystem::path dir =
      (std::filesystem::path(exe).parent_path() / ".." / "share" / "edgefusion" / "models").lexically_normal();
  std::error_code ec;
  return std::filesystem::is_directory(dir, ec) ? dir.string() : std::string();
}

std::string models_dir() {
  const std::string env = env_or_empty("EDGEFUSION_MODELS_DIR");
  if (!env.empty()) return env;
  // The program's location does not change while it runs: looked up once.
  static const std::string installed = installed_models_dir(this_program_path());
  return installed.empty() ? std::string(EF_MODELS_DIR) : installed;
}

bool models_dir_overridden() { return !env_or_empty("EDGEFUSION_MODELS_DIR").empty(); }

bool is_synthetic_source(const std::string& source_uri) { return source_uri.rfind("synthetic", 0) == 0; }

std::string default_model_path(const std::string& source_uri) {
  const std::string env = env_or_empty("EDGEFUSION_MODEL");
  if (!env.empty()) return env;
  return (std::filesystem::path(models_dir()) /
          (is_synthetic_source(source_uri) ? kSyntheticModelFile : kRealModelFile)).string();
}

Status check_model_file(const std::string& path, bool is_default) {
  std::error_code ec;
  if (std::filesystem::is_regular_file(path, ec)) return Status::success();
  std::string why = "model file '" + path + "' not found";
  if (is_default)
    why += env_or_empty("EDGEFUSION_MODEL").empty() ? " (the default: a shipped model)"
                                                    : " (the default, from $EDGEFUSION_MODEL)";
  why += ". The shipped models in " + models_dir() + " (" + kSyntheticModelFile + ", " + kRealModelFile +
         ") are written by models/train.sh and models/import_deeplab.sh (see models/README.md); "
         "or convert a network with 'edgefusion model import --onnx|--tflite FILE --calibration URI --out MODEL'. "
         "Then pass --model MODEL or set EDGEFUSION_MODEL.";
  return error(ErrorCode::kNotFound, why);
}

}  // namespace ef::pipeline
