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

std::string models_dir() {
  const std::string env = env_or_empty("EDGEFUSION_MODELS_DIR");
  return env.empty() ? std::string(EF_MODELS_DIR) : env;
}

bool models_dir_overridden() { return !env_or_empty("EDGEFUSION_MODELS_DIR").empty(); }

bool is_synthetic_source(const std::string& source_uri) { return source_uri.rfind("synthetic", 0) == 0; }

std::string default_model_path(const std::string& source_uri) {
  const std::string env = env_or_empty("EDGEFUSION_MODEL");
  if (!env.empty()) return env;
  return (std::filesystem::path(EF_MODELS_DIR) /
          (is_synthetic_source(source_uri) ? kSyntheticModelFile : kRealModelFile)).string();
}

Status check_model_file(const std::string& path, bool is_default) {
  std::error_code ec;
  if (std::filesystem::is_regular_file(path, ec)) return Status::success();
  std::string why = "model file '" + path + "' not found";
  if (is_default)
    why += env_or_empty("EDGEFUSION_MODEL").empty() ? " (the default: a shipped model)"
                                                    : " (the default, from $EDGEFUSION_MODEL)";
  why += ". The shipped models in " + std::string(EF_MODELS_DIR) + " (" + kSyntheticModelFile + ", " +
         kRealModelFile + ") are written by models/train.sh and models/import_deeplab.sh (see models/README.md); "
         "or convert a network with 'edgefusion model import --onnx|--tflite FILE --calibration URI --out MODEL'. "
         "Then pass --model MODEL or set EDGEFUSION_MODEL.";
  return error(ErrorCode::kNotFound, why);
}

}  // namespace ef::pipeline
