// `edgefusion model info|import`: what a .efm network is and costs, and the bridge to the Python
// exporter that turns an ONNX network into one (models/edgefusion_models/import_onnx.py).
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "args.h"
#include "commands.h"
#include "pipeline/model_paths.h"
#include "nn/executor.h"
#include "nn/model_format.h"
#include "semantic/model_stats.h"
#include "semantic/segmenter.h"

extern char** environ;

namespace ef::app {

using pipeline::check_model_file;
using pipeline::models_dir;
using pipeline::models_dir_overridden;

namespace {

namespace fs = std::filesystem;

constexpr const char* kPython = "/usr/bin/python3";
constexpr const char* kOnnxModule = "edgefusion_models.import_onnx";
constexpr const char* kTfliteModule = "edgefusion_models.import_tflite";
// Debian packages the importers run on (python3 itself, NumPy, OpenCV for the calibration frames;
// ONNX for the ONNX importer: the TFLite reader is our own).
constexpr const char* kDebianPackages = "python3 python3-onnx python3-numpy python3-opencv";

const std::vector<OptionSpec> kInfoOptions = {
    {"--isa", "NAME", "kernel variants as chosen with this ISA cap (scalar, sse41, avx2, avxvnni, avx512vnni, neon, "
                      "neondot); default the best the CPU and EF_ISA allow"},
};

const std::vector<OptionSpec> kImportOptions = {
    {"--onnx", "FILE", "a float network in ONNX: input N x 4 x H x W (normalised R, G, B, depth), output the class "
                       "logits"},
    {"--tflite", "FILE", "a TFLite network (float activations; int8 or float weights), e.g. DeepLabv3-MobileNetV2: "
                         "input 1 x H x W x 3 or 4, output the class logits"},
    {"--calibration", "URI", "frame source(s) whose frames set the int8 quantisation ranges (see edgefusion run "
                             "--help); several sources separated by '|' share the frames", true},
    {"--out", "MODEL", "the .efm file to write", true},
    {"--frames", "N", "calibration frames to use; default the importer's"},
    {"--input", "WxH", "TFLite: the network input size (each side 8k+1, e.g. 257x193); default the file's"},
    {"--class-map", "JSON", "TFLite: source class -> target class (e.g. ADE20K -> NYUv2 13) stored in the model: "
                            "the runtime sums the probabilities of the source classes of each target"},
    {"--labels", "FILE", "TFLite: source class names, lines 'index<TAB>name'"},
    {"--golden-dir", "DIR", "also write golden files (the first calibration frame's int8 tensors and output) for the "
                            "C++ bit-exactness test"},
};

void print_model_help() {
  std::printf(
      "Usage: edgefusion model <info|import> ...   (edgefusion model <kind> --help for each)\n\n"
      "  info MODEL [--isa NAME]               name, input/output shapes, classes, layers, parameters, MACs\n"
      "                                        per forward pass, arena and packed weight bytes, and the kernel\n"
      "                                        variant of each layer\n"
      "  import --onnx FILE --calibration URI --out MODEL [--frames N]\n"
      "                                        quantise an ONNX network to an int8 .efm (runs %s -m %s)\n"
      "  import --tflite FILE --calibration URI --out MODEL [--input WxH] [--class-map JSON] [--labels FILE]\n"
      "                                        the same for a TFLite network (runs %s -m %s)\n"
      "The shipped models are in models/; $EDGEFUSION_MODEL overrides the one segment and run use.\n",
      kPython, kOnnxModule, kPython, kTfliteModule);
}

std::string shape_text(const nn::TensorDesc& t) {
  return std::to_string(t.h) + "x" + std::to_string(t.w) + "x" + std::to_string(t.c);
}

// Kernel geometry of a layer for the table: "3x3 s2 d1", "x2 bilinear"; "" when it has none.
std::string geometry_text(const nn::LayerDesc& l) {
  using nn::LayerType;
  char buf[64] = "";
  switch (l.type) {
    case LayerType::kConv2d:
    case LayerType::kDepthwiseConv2d:
      std::snprintf(buf, sizeof buf, "%ux%u s%u d%u", l.kernel_h, l.kernel_w, l.stride_h, l.dilation_h);
      break;
    case LayerType::kPointwiseConv2d:
      std::snprintf(buf, sizeof buf, "1x1");
      break;
    case LayerType::kMaxPool:
    case LayerType::kAvgPool:
      std::snprintf(buf, sizeof buf, "%ux%u s%u", l.kernel_h, l.kernel_w, l.stride_h);
      break;
    case LayerType::kUpsample:
      std::snprintf(buf, sizeof buf, "x%u %s", l.factor, l.mode == nn::UpsampleMode::kBilinear ? "bilinear" : "nearest");
      break;
    case LayerType::kResizeBilinear:
      std::snprintf(buf, sizeof buf, "align-corners");
      break;
    default:
      break;
  }
  return buf;
}

int model_info(int argc, char** argv) {
  constexpr const char* kCmd = "edgefusion model info";
  if (wants_help(argc, argv, 3)) {
    std::printf("%s", format_help("edgefusion model info MODEL [--isa NAME]",
                                  "Prints a .efm network: name, input and output shapes, class names, layer count,\n"
                                  "parameters (int8 weights + int32 biases), MACs per forward pass (sum over the\n"
                                  "convolutions of out_h*out_w*cout*kh*kw*cin_per_group), the executor's activation\n"
                                  "arena and repacked weight bytes, and each layer with its kernel variant.",
                                  kInfoOptions).c_str());
    return 0;
  }
  auto args = parse_args(kCmd, kInfoOptions, 1, argc, argv, 3);
  if (!args.ok()) return report_error(kCmd, args.error(), 2);
  nn::ExecutorOptions eo;
  if (args->has("--isa")) {
    auto isa = semantic::parse_isa(args->get("--isa"), "--isa");
    if (!isa.ok()) return report_error(kCmd, isa.error(), 2);
    eo.max_isa = *isa;
  }
  const std::string path = args->positionals()[0];
  if (Status s = check_model_file(path, false); !s.ok()) return report_error(kCmd, s.error(), 1);
  auto model = nn::load_model(path);
  if (!model.ok()) return report_error(kCmd, model.error(), 1);
  auto ex = nn::Executor::create(*model, eo);
  if (!ex.ok()) return report_error(kCmd, ex.error(), 1);
  const nn::ModelDesc& d = model->desc;
  const semantic::ModelStats stats = semantic::compute_model_stats(d);
  const nn::TensorDesc& in = d.tensors[d.input_tensor];
  const nn::TensorDesc& out = d.tensors[d.output_tensor];
  std::error_code ec;
  const auto file_bytes = fs::file_size(path, ec);

  std::printf("%-20s %s\n", "name", d.name.c_str());
  std::printf("%-20s %s (%llu bytes)\n", "file", path.c_str(), ec ? 0ull : static_cast<unsigned long long>(file_bytes));
  std::printf("%-20s %s (HxWxC) int8 (scale %g, zero point %d)\n", "input", shape_text(in).c_str(), double(in.scale),
              in.zero_point);
  static const char* const kChannel[] = {"R", "G", "B", "depth"};
  std::string norm;
  for (std::size_t c = 0; c < d.input_mean.size(); ++c) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "%s%s (v - %g) * %g", c ? ", " : "", c < 4 ? kChannel[c] : "?",
                  double(d.input_mean[c]), double(d.input_scale[c]));
    norm += buf;
  }
  std::printf("%-20s %s\n", "normalisation", norm.c_str());
  std::printf("%-20s %s (HxWxC) float32 (softmax probabilities)\n", "output", shape_text(out).c_str());
  std::string names;
  for (const auto& n : d.class_names) names += (names.empty() ? "" : " ") + n;
  std::printf("%-20s %zu\n", "classes", d.class_names.size());
  std::printf("%-20s %s\n", "class_names", names.c_str());
  if (!d.class_map.empty()) {
    // Target class <- its source classes, e.g. "chair <- chair armchair swivel".
    std::printf("%-20s %zu target classes, each the sum of its source classes' probabilities\n", "class_map",
                d.target_class_names.size());
    for (std::size_t t = 0; t < d.target_class_names.size(); ++t) {
      std::string from;
      for (std::size_t c = 0; c < d.class_map.size(); ++c)
        if (d.class_map[c] == t) from += " " + d.class_names[c];
      std::printf("  %-18s <-%s\n", d.target_class_names[t].c_str(), from.empty() ? " (none)" : from.c_str());
    }
  }
  std::printf("%-20s %zu\n", "layers", d.layers.size());
  std::printf("%-20s %d\n", "conv_layers", stats.conv_layers);
  std::printf("%-20s %llu\n", "parameters", static_cast<unsigned long long>(stats.parameters));
  std::printf("%-20s %llu\n", "macs", static_cast<unsigned long long>(stats.macs));
  std::printf("%-20s %.3f\n", "mmacs", double(stats.macs) * 1e-6);
  std::printf("%-20s %llu\n", "weight_bytes", static_cast<unsigned long long>(stats.weight_bytes));
  std::printf("%-20s %zu\n", "arena_bytes", (*ex)->arena_bytes());
  std::printf("%-20s %zu\n", "packed_weight_bytes", (*ex)->packed_bytes());
  std::printf("%-20s %s\n", "kernel_isa", semantic::kernel_isa_summary(**ex, d.layers.size()).c_str());

  // The layer table, each column as wide as its longest entry (issue 33: rows stay aligned whatever
  // the model's shapes and kernel names).
  struct Row {
    std::string type, kernel, io, variant;
  };
  std::vector<Row> rows;
  std::size_t w_type = 4, w_kernel = 6, w_io = 15, w_variant = 14;
  for (std::size_t i = 0; i < d.layers.size(); ++i) {
    const nn::LayerDesc& l = d.layers[i];
    Row r;
    r.type = nn::layer_type_name(l.type);
    r.kernel = geometry_text(l);
    r.io = shape_text(d.tensors[l.inputs[0]]);
    if (l.inputs.size() > 1) r.io += " +" + std::to_string(l.inputs.size() - 1);
    r.io += " -> " + shape_text(d.tensors[l.output]);
    const char* variant = (*ex)->kernel_name(i);
    r.variant = *variant ? variant : "(reference)";
    w_type = std::max(w_type, r.type.size());
    w_kernel = std::max(w_kernel, r.kernel.size());
    w_io = std::max(w_io, r.io.size());
    w_variant = std::max(w_variant, r.variant.size());
    rows.push_back(std::move(r));
  }
  const auto row = [&](const std::string& n, const Row& r, const std::string& macs) {
    std::printf("%5s  %-*s  %-*s  %-*s  %-*s  %10s\n", n.c_str(), int(w_type), r.type.c_str(), int(w_kernel),
                r.kernel.c_str(), int(w_io), r.io.c_str(), int(w_variant), r.variant.c_str(), macs.c_str());
  };
  std::printf("\n");
  row("layer", Row{"type", "kernel", "input -> output", "kernel variant"}, "MMAC");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    char macs[32];
    std::snprintf(macs, sizeof macs, "%.3f", double(stats.layers[i].macs) * 1e-6);
    row(std::to_string(i), rows[i], macs);
  }
  return 0;
}

// Runs argv[0] with `env` and waits. Returns the exit status (128 + signal when killed), or an error
// when it cannot start.
Result<int> spawn_and_wait(const std::vector<std::string>& args, const std::vector<std::string>& env) {
  std::vector<char*> argv, envp;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  for (const auto& e : env) envp.push_back(const_cast<char*>(e.c_str()));
  envp.push_back(nullptr);
  std::fflush(stdout);
  std::fflush(stderr);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, args[0].c_str(), nullptr, nullptr, argv.data(), envp.data());
  if (rc != 0) return error(ErrorCode::kIoError, "cannot run " + args[0] + ": " + std::strerror(rc));
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return error(ErrorCode::kIoError, "waiting for " + args[0] + ": " + std::strerror(errno));
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

// The environment with PYTHONPATH = `dir` in front of any PYTHONPATH already set.
std::vector<std::string> python_env(const std::string& dir) {
  std::vector<std::string> env;
  std::string pythonpath = "PYTHONPATH=" + dir;
  for (char** e = environ; e && *e; ++e) {
    if (std::strncmp(*e, "PYTHONPATH=", 11) == 0) {
      if ((*e)[11] != '\0') pythonpath += std::string(":") + (*e + 11);
      continue;
    }
    env.emplace_back(*e);
  }
  env.push_back(pythonpath);
  return env;
}

int model_import(int argc, char** argv) {
  constexpr const char* kCmd = "edgefusion model import";
  constexpr const char* kUsage =
      "edgefusion model import (--onnx FILE | --tflite FILE [--input WxH] [--class-map JSON] [--labels FILE]) "
      "--calibration URI --out MODEL [--frames N] [--golden-dir DIR]";
  if (wants_help(argc, argv, 3)) {
    std::printf("%s", format_help(kUsage,
                                  std::string("Quantises a float segmentation network (ONNX or TFLite) to an int8 .efm "
                                              "model with the frames\nof a source as calibration data. Runs ") +
                                      kPython + " -m " + kOnnxModule + " or " + kTfliteModule +
                                      " with PYTHONPATH = the\nmodels/ folder of this build (" + models_dir() +
                                      "; $EDGEFUSION_MODELS_DIR overrides it) and returns its exit code.\n"
                                      "Debian packages: " + kDebianPackages + ".",
                                  kImportOptions).c_str());
    return 0;
  }
  auto args = parse_args(kCmd, kImportOptions, 0, argc, argv, 3);
  if (!args.ok()) return report_error(kCmd, args.error(), 2);
  auto frames = args->get_int("--frames", -1, 1, INT64_MAX);
  if (!frames.ok()) return report_error(kCmd, frames.error(), 2);
  const bool onnx = args->has("--onnx"), tfl = args->has("--tflite");
  if (onnx == tfl)
    return report_error(kCmd, error(ErrorCode::kInvalidArgument,
                                    std::string(onnx ? "--onnx and --tflite both given" : "no network given") +
                                        ": give exactly one of --onnx FILE and --tflite FILE"), 2);
  for (const char* opt : {"--input", "--class-map", "--labels"})
    if (onnx && args->has(opt))
      return report_error(kCmd, error(ErrorCode::kInvalidArgument, std::string(opt) + " applies to --tflite only"), 2);
  const char* module_name = onnx ? kOnnxModule : kTfliteModule;
  const char* module_file = onnx ? "import_onnx.py" : "import_tflite.py";

  // What is missing is said before anything runs, with what to install: a Python traceback is a
  // poor error message.
  const std::string dir = models_dir();
  const fs::path module = fs::path(dir) / "edgefusion_models" / module_file;
  std::error_code ec;
  if (!fs::is_regular_file(module, ec))
    return report_error(kCmd, error(ErrorCode::kNotFound,
                                    std::string("the Python module ") + module_name + " is missing: " +
                                        module.string() + " does not exist (models folder " + dir +
                                        (models_dir_overridden() ? ", from $EDGEFUSION_MODELS_DIR" : "") +
                                        "). It ships in the models/ folder of the EdgeFusion sources; point "
                                        "EDGEFUSION_MODELS_DIR at that folder. It runs on " + kPython +
                                        " with the Debian packages " + kDebianPackages), 1);
  if (access(kPython, X_OK) != 0)
    return report_error(kCmd, error(ErrorCode::kNotFound, std::string(kPython) + " is missing; install the Debian "
                                                          "packages " + kDebianPackages + " (apt-get install " +
                                                          kDebianPackages + ")"), 1);
  const std::vector<std::string> env = python_env(dir);
  // find_spec locates a module without importing it: fast, and no side effects. Exit status bit i
  // is set when module i is missing (the ONNX package only for the ONNX importer).
  static const char* const kModules[][2] = {{"numpy", "python3-numpy"}, {"cv2", "python3-opencv"},
                                            {"onnx", "python3-onnx"}};
  const int checked = onnx ? 3 : 2;
  auto missing_bits = spawn_and_wait(
      {kPython, "-c",
       std::string("import importlib.util as u\nm=0\nfor i,n in enumerate(('numpy','cv2','onnx')[:") +
           std::to_string(checked) + "]):\n    m|=(u.find_spec(n) is None)<<i\nraise SystemExit(m)"},
      env);
  if (!missing_bits.ok()) return report_error(kCmd, missing_bits.error(), 1);
  if (*missing_bits != 0) {
    std::string mods, pkgs;
    for (int i = 0; i < checked; ++i)
      if (*missing_bits & (1 << i)) {
        mods += std::string(mods.empty() ? "" : ", ") + kModules[i][0];
        pkgs += std::string(pkgs.empty() ? "" : " ") + kModules[i][1];
      }
    if (*missing_bits >= 8) mods = "a working Python (the module check exited " + std::to_string(*missing_bits) + ")";
    return report_error(kCmd, error(ErrorCode::kNotFound,
                                    std::string(kPython) + " lacks " + mods + "; install the Debian packages " +
                                        (pkgs.empty() ? std::string(kDebianPackages) : pkgs) + " (the importer needs " +
                                        kDebianPackages + ")"), 1);
  }

  char exe[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (n <= 0) return report_error(kCmd, error(ErrorCode::kIoError, std::string("readlink /proc/self/exe: ") +
                                                                       std::strerror(errno)), 1);
  exe[n] = '\0';
  std::vector<std::string> cmd = {kPython, "-m", module_name, onnx ? "--onnx" : "--tflite",
                                  args->get(onnx ? "--onnx" : "--tflite"), "--calibration", args->get("--calibration"),
                                  "--out", args->get("--out"), "--edgefusion", exe};
  if (args->has("--frames")) {
    cmd.push_back("--frames");
    cmd.push_back(std::to_string(*frames));
  }
  for (const char* opt : {"--input", "--class-map", "--labels", "--golden-dir"})
    if (args->has(opt)) {
      cmd.push_back(opt);
      cmd.push_back(args->get(opt));
    }
  auto code = spawn_and_wait(cmd, env);
  if (!code.ok()) return report_error(kCmd, code.error(), 1);
  if (*code != 0) std::fprintf(stderr, "%s: %s -m %s exited with status %d\n", kCmd, kPython, module_name, *code);
  return *code;
}

}  // namespace

int cmd_model(int argc, char** argv) {
  if (argc < 3 || std::string(argv[2]) == "--help" || std::string(argv[2]) == "-h") {
    print_model_help();
    return argc < 3 ? 2 : 0;
  }
  const std::string kind = argv[2];
  if (kind == "info") return model_info(argc, argv);
  if (kind == "import") return model_import(argc, argv);
  std::fprintf(stderr, "edgefusion model: unknown kind '%s' (expected info or import)\n", kind.c_str());
  return 2;
}

const std::vector<OptionSpec>& model_info_options() { return kInfoOptions; }
const std::vector<OptionSpec>& model_import_options() { return kImportOptions; }

}  // namespace ef::app
