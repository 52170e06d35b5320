// Times the whole forward pass of a segmentation network (nn::Executor::run: input quantisation,
// every layer, softmax) on one thread, once per ISA cap the CPU can run, and prints the model's size
// and cost.
//   bench_nn_model [--model FILE.efm] [--reps R] [--min-ms T]
// Model: the shipped one by default ($EDGEFUSION_MODEL, else models/edgefusion-seg.efm of the source
// tree), --model another. Input: one frame of colour and depth values (random colour 0..255, depth
// 0.4..6 m, fixed seed); the time does not depend on the values.
// Per ISA cap (scalar = the reference layers, then sse41, avx2, avxvnni, avx512vnni on x86-64 or
// neon, neondot on AArch64): the executor is created with ExecutorOptions::max_isa at that level,
// its probabilities are first checked bit for bit against the scalar run (a benchmark of wrong code
// is worthless), then timed. A cap that selects exactly the kernels of the previous cap is not timed
// again. Times: thread CPU time, median of R runs (default 15), each a batch of calls lasting at
// least T ms (default 50); "iqr" is the interquartile range over the median. GMAC/s counts the
// model's convolution MACs (padding taps included, as `edgefusion model info` counts them).
// Per-layer-type times are not printed: the executor runs its layers as one call and has no
// per-layer timing hook (nn/executor.h). Pin the CPU first: taskset -c 1 build/release/bench/bench_nn_model
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "bench/bench_timing.h"
#include "pipeline/model_paths.h"
#include "kernels/variants.h"
#include "nn/executor.h"
#include "nn/model_format.h"
#include "platform/cpu/cpu_features.h"
#include "semantic/model_stats.h"

namespace {

using ef::kernels::Isa;

using ef::bench::Timing;
using ef::bench::time_calls;

// The kernel variant of every layer, joined: two caps that give the same string run the same code.
std::string kernel_signature(const ef::nn::Executor& ex, std::size_t layers) {
  std::string s;
  for (std::size_t i = 0; i < layers; ++i) s += std::string(ex.kernel_name(i)) + ";";
  return s;
}

int usage() {
  std::fprintf(stderr, "usage: bench_nn_model [--model FILE.efm] [--reps R] [--min-ms T]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string model_path;
  int reps = 15;
  double min_ms = 50.0;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (i + 1 >= argc) return usage();
    if (arg == "--model") model_path = argv[++i];
    else if (arg == "--reps") reps = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--min-ms") min_ms = std::max(0.0, std::atof(argv[++i]));
    else return usage();
  }
  const bool is_default = model_path.empty();
  if (is_default) model_path = ef::pipeline::default_model_path("synthetic:");  // EdgeSegNet, the headline's figure
  if (ef::Status s = ef::pipeline::check_model_file(model_path, is_default); !s.ok()) {
    std::fprintf(stderr, "bench_nn_model: %s\n", ef::to_string(s.error()).c_str());
    return 1;
  }
  ef::Result<ef::nn::Model> model = ef::nn::load_model(model_path);
  if (!model.ok()) {
    std::fprintf(stderr, "bench_nn_model: %s\n", ef::to_string(model.error()).c_str());
    return 1;
  }
  const ef::nn::ModelDesc& d = model->desc;
  const ef::semantic::ModelStats stats = ef::semantic::compute_model_stats(d);
  const ef::nn::TensorDesc& in = d.tensors[d.input_tensor];
  const ef::nn::TensorDesc& out = d.tensors[d.output_tensor];

  std::printf("bench_nn_model: CPU features: %s (detected: %s); one thread; thread CPU time, median of %d runs of "
              ">= %.1f ms\n", ef::cpu_features().describe().c_str(), ef::detected_cpu_features().describe().c_str(),
              reps, min_ms);
  cpu_set_t allowed;
  if (sched_getaffinity(0, sizeof allowed, &allowed) == 0 && CPU_COUNT(&allowed) > 1)
    std::printf("note: this process may run on %d CPUs; pin it (taskset -c 1) for stable numbers\n",
                CPU_COUNT(&allowed));
  std::printf("model %s (%s): input %ux%ux%u, output %ux%ux%u, %zu layers (%d convolutions), %llu parameters, "
              "%.3f MMAC per forward pass\n", d.name.c_str(), model_path.c_str(), in.h, in.w, in.c, out.h, out.w,
              out.c, d.layers.size(), stats.conv_layers, static_cast<unsigned long long>(stats.parameters),
              double(stats.macs) * 1e-6);

  // One frame's input: random colour, depth in the working range.
  std::vector<float> input(std::size_t(in.h) * in.w * in.c);
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> color(0.0f, 255.0f), depth(0.4f, 6.0f);
  for (std::size_t i = 0; i < input.size(); ++i) input[i] = (in.c == 4 && i % 4 == 3) ? depth(rng) : color(rng);
  std::vector<float> reference(out.elements()), probs(out.elements());

  std::printf("\n  %-11s %11s %8s %11s %11s   %s\n", "ISA cap", "ms/frame", "iqr", "MMAC", "GMAC/s", "kernels");
  std::string previous_signature, previous_isa;
  double scalar_s = 0;
  for (Isa isa : {Isa::scalar, Isa::sse41, Isa::avx2, Isa::avxvnni, Isa::avx512vnni, Isa::neon, Isa::neondot}) {
    const char* name = ef::kernels::isa_name(isa);
#if defined(__x86_64__)
    if (isa == Isa::neon || isa == Isa::neondot) continue;  // the other architecture's levels
#elif defined(__aarch64__)
    if (isa != Isa::scalar && isa != Isa::neon && isa != Isa::neondot) continue;
#endif
    if (!ef::kernels::isa_available(isa)) {
      std::printf("  %-11s skipped (CPU lacks it or EF_ISA caps it)\n", name);
      continue;
    }
    ef::nn::ExecutorOptions eo;
    eo.max_isa = isa;
    auto ex = ef::nn::Executor::create(*model, eo);
    if (!ex.ok()) {
      std::fprintf(stderr, "bench_nn_model: %s\n", ef::to_string(ex.error()).c_str());
      return 1;
    }
    const std::string signature = kernel_signature(**ex, d.layers.size());
    if (signature == previous_signature) {
      std::printf("  %-11s same kernels as %s; not timed again\n", name, previous_isa.c_str());
      continue;
    }
    previous_signature = signature;
    previous_isa = name;

    // Correctness first: every probability bit equal to the scalar reference's.
    std::vector<float>& dst = isa == Isa::scalar ? reference : probs;
    if (ef::Status s = (*ex)->run(input.data(), input.size(), dst.data(), dst.size()); !s.ok()) {
      std::fprintf(stderr, "bench_nn_model: %s\n", ef::to_string(s.error()).c_str());
      return 1;
    }
    if (isa != Isa::scalar && std::memcmp(probs.data(), reference.data(), probs.size() * sizeof(float)) != 0) {
      std::size_t diff = 0;
      for (std::size_t i = 0; i < probs.size(); ++i) diff += std::memcmp(&probs[i], &reference[i], sizeof(float)) != 0;
      std::fflush(stdout);
      std::fprintf(stderr, "bench_nn_model: FATAL: cap %s: %zu of %zu probabilities differ from the scalar reference\n",
                   name, diff, probs.size());
      return 3;
    }

    const Timing t = time_calls([&] { (void)(*ex)->run(input.data(), input.size(), probs.data(), probs.size()); },
                                reps, min_ms);
    if (isa == Isa::scalar) scalar_s = t.median;
    std::printf("  %-11s %11.3f %7.1f%% %11.3f %11.2f   %s", name, t.median * 1e3, 100.0 * t.iqr,
                double(stats.macs) * 1e-6, double(stats.macs) / t.median * 1e-9,
                ef::semantic::kernel_isa_summary(**ex, d.layers.size()).c_str());
    if (isa != Isa::scalar && scalar_s > 0) std::printf("  (%.1fx scalar)", scalar_s / t.median);
    std::printf("\n");
  }
  std::printf("\nper-layer-type breakdown: not available (the executor has no per-layer timing hook)\n");
  return 0;
}
