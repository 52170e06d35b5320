// Where the shipped segmentation model and the Python model tools are found, for the `segment` and
// `model` commands and for bench_nn_model.
#pragma once

#include <string>

#include "core/result.h"

namespace ef::pipeline {

// The models/ folder of the source tree this program was built from (EF_MODELS_DIR, a compile
// definition), or $EDGEFUSION_MODELS_DIR when set: the PYTHONPATH of `edgefusion model import`.
std::string models_dir();
// True when $EDGEFUSION_MODELS_DIR chose models_dir() (for messages).
bool models_dir_overridden();

// The model used when --model is not given: $EDGEFUSION_MODEL when set, else
// <EF_MODELS_DIR>/edgefusion-seg.efm (the shipped model).
std::string default_model_path();

// Ok when `path` is an existing file. Otherwise a kNotFound error that names the path, says whether
// it was the default, and says how to get a model (train and export it, or import an ONNX network).
Status check_model_file(const std::string& path, bool is_default);

}  // namespace ef::pipeline
