// Where the shipped segmentation model and the Python model tools are found, for the `segment` and
// `model` commands and for bench_nn_model.
#pragma once

#include <string>

#include "core/result.h"

namespace ef::pipeline {

// The folder of the shipped models and the Python model tools (the PYTHONPATH of `edgefusion model
// import`), found where the program is (issue 32), in this order:
//   1. $EDGEFUSION_MODELS_DIR when set;
//   2. <the program's folder>/../share/edgefusion/models when it exists: an installed program (any
//      install prefix, the package's /usr, a package unpacked into a folder);
//   3. the models/ folder of the source tree it was built from (EF_MODELS_DIR, a compile
//      definition): a program run from its build tree.
std::string models_dir();
// True when $EDGEFUSION_MODELS_DIR chose models_dir() (for messages).
bool models_dir_overridden();
// Step 2 for a program at `exe`: "<exe's folder>/../share/edgefusion/models" (normalised) when that
// folder exists, else empty.
std::string installed_models_dir(const std::string& exe);
// Where the running program is (/proc/self/exe; under qemu-user the emulated program's path), or
// empty when the system does not say.
std::string this_program_path();

// The shipped models (in models_dir()): EdgeSegNet, trained on the synthetic rooms (RGB-D,
// 160x120), and DeepLabv3-MobileNetV2 trained on ADE20K photographs, imported at 257x193 with its
// classes mapped to the NYUv2 13 (RGB; models/MODEL_CARD-deeplab.md).
inline constexpr const char* kSyntheticModelFile = "edgefusion-seg.efm";
inline constexpr const char* kRealModelFile = "deeplabv3-mnv2-nyu13.efm";

// True for the built-in rendered rooms (synthetic: URIs); recordings and cameras are real.
bool is_synthetic_source(const std::string& source_uri);

// The model used when --model is not given: $EDGEFUSION_MODEL when set, else the shipped model for
// the source: EdgeSegNet for the synthetic rooms it was trained on, the real-photograph network for
// recordings and cameras (docs/results.md, issue 28, has the measurements behind the choice).
std::string default_model_path(const std::string& source_uri);

// Ok when `path` is an existing file. Otherwise a kNotFound error that names the path, says whether
// it was the default, and says how to get a model (train and export it, or import an ONNX network).
Status check_model_file(const std::string& path, bool is_default);

}  // namespace ef::pipeline
