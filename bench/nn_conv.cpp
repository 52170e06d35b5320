// Times the int8 convolution kernels of the CNN runtime (nn/conv_kernels.h) against XNNPACK's int8
// convolution operators on the same shapes, in one process and on one thread, and against the int8
// multiply-accumulate peak of each ISA level (bench/nn_peak.h). Issue 4's goal: at least 1.0x
// XNNPACK on every shape, on the AVX2 path and on the best path.
//   bench_nn_conv [--reps R] [--min-ms T] [--shape SUBSTR] [--model FILE.efm]
// Shapes: 3x3 32->32 at 120x160 plus the convolutions of the segmentation model (a provisional list
// until the model exists; --model takes the distinct convolution shapes of a .efm file instead, each
// timed once and counted once per layer in the per-frame total). Per shape:
//   XNNPACK    its qc8 operator (per-channel weight scales, fp32 requantisation: the arithmetic of
//              nn/requantize.h, so it must give the reference's bytes too), created and set up once,
//              xnn_run_operator timed with no thread pool. Twice where the CPU has AVX-512 and cpuinfo's
//              header was found: the library as it configures itself ("XNNPACK", capped at EF_ISA), and
//              a second copy of it (dlmopen) whose cpuinfo is capped at AVX2 ("XNNPACK@avx2").
//   ours       every row of the family's table (conv_i8 for k x k and 1 x 1, dwconv_i8 for depthwise)
//              that the CPU runs: weights packed once into a 64-byte-aligned buffer, ConvKernel::run
//              timed. Each row's output is first checked byte for byte against the scalar reference,
//              with a guard after the output (a mismatch aborts: a benchmark of wrong code is worthless).
// "AVX2 path" / "best path": the row the executor selects (the last runnable row, kernels/variants.h)
// with the CPU capped at AVX2 / as detected (capped by EF_ISA); the AVX2 path is compared with
// XNNPACK@avx2, the best path with XNNPACK. On AArch64 the first is the NEON path (XNNPACK uncapped).
// Times: thread CPU time, median of R runs (default 15), each a batch of calls lasting at least T ms
// (default 2); "iqr" is the interquartile range over the median. GMAC/s counts one multiply-accumulate
// per weight tap per output value, padding taps included (as XNNPACK's own benchmarks count).
// Fraction of peak: our rows against the peak of their own ISA, XNNPACK against the best ISA's peak
// (XNNPACK@avx2 against AVX2's). Pin the CPU first: taskset -c 1 build/release/bench/bench_nn_conv
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "bench/bench_timing.h"
#include "bench/nn_peak.h"
#include "kernels/variants.h"
#include "nn/conv_kernels.h"
#include "nn/layers_ref.h"
#include "nn/model_format.h"
#include "platform/cpu/cpu_features.h"

#if defined(EF_HAVE_XNNPACK)
#include <xnnpack.h>
#endif
#if defined(EF_HAVE_CPUINFO)
#include <cpuinfo.h>
#include <dlfcn.h>
#endif

namespace {

using ef::kernels::Isa;
using Variant = ef::kernels::KernelVariant<ef::nn::ConvKernelPtr>;

using ef::bench::Timing;
using ef::bench::time_calls;

// A zero-filled, 64-byte-aligned byte buffer (aligned_alloc needs a size that is a multiple of 64).
struct FreeDeleter {
  void operator()(void* p) const { std::free(p); }
};
using AlignedBytes = std::unique_ptr<uint8_t, FreeDeleter>;
AlignedBytes aligned_bytes(std::size_t n) {
  const std::size_t rounded = (std::max<std::size_t>(n, 1) + 63) / 64 * 64;
  auto* p = static_cast<uint8_t*>(std::aligned_alloc(64, rounded));
  if (!p) {
    std::fprintf(stderr, "bench_nn_conv: out of memory (%zu bytes)\n", n);
    std::exit(1);
  }
  std::memset(p, 0, rounded);
  return AlignedBytes(p);
}

// ---------------------------------------------------------------------------------------------------
// Shapes.

struct Shape {
  std::string name;
  bool depthwise = false;
  bool in_model = false;     // a layer of the segmentation model (counted in the per-frame total)
  bool provisional = false;  // from the planned model; the model issue replaces these
  int count = 1;             // layers of the model with exactly this shape (--model: timed once)
  int in_h = 0, in_w = 0, in_c = 0, out_c = 0;
  int kernel_h = 1, kernel_w = 1, stride_h = 1, stride_w = 1, dilation_h = 1, dilation_w = 1;
  int pad_top = 0, pad_left = 0, pad_bottom = 0, pad_right = 0;

  bool same_geometry(const Shape& o) const {
    return depthwise == o.depthwise && in_h == o.in_h && in_w == o.in_w && in_c == o.in_c && out_c == o.out_c &&
           kernel_h == o.kernel_h && kernel_w == o.kernel_w && stride_h == o.stride_h && stride_w == o.stride_w &&
           dilation_h == o.dilation_h && dilation_w == o.dilation_w && pad_top == o.pad_top &&
           pad_left == o.pad_left && pad_bottom == o.pad_bottom && pad_right == o.pad_right;
  }

  // Output size, as the .efm loader and XNNPACK compute it.
  int out_h() const { return (in_h + pad_top + pad_bottom - dilation_h * (kernel_h - 1) - 1) / stride_h + 1; }
  int out_w() const { return (in_w + pad_left + pad_right - dilation_w * (kernel_w - 1) - 1) / stride_w + 1; }
  double macs() const {
    const double taps = double(kernel_h) * kernel_w * (depthwise ? 1 : in_c);
    return double(out_h()) * out_w() * out_c * taps;
  }
};

// A k x k convolution (k = 1: pointwise) or depthwise (cin = cout) with "same" padding
// dilation * (k - 1) / 2 on every side.
Shape make_shape(const char* name, bool depthwise, int h, int w, int cin, int cout, int k, int stride,
                 int dilation, bool provisional) {
  Shape s;
  s.name = name;
  s.depthwise = depthwise;
  s.in_model = s.provisional = provisional;
  s.in_h = h, s.in_w = w, s.in_c = cin, s.out_c = cout;
  s.kernel_h = s.kernel_w = k;
  s.stride_h = s.stride_w = stride;
  s.dilation_h = s.dilation_w = dilation;
  s.pad_top = s.pad_left = s.pad_bottom = s.pad_right = dilation * (k - 1) / 2;
  return s;
}

// Issue 4's shapes: 3x3 32->32 at 120x160, and the planned segmentation model (input 120x160x4): an
// encoder of a strided stem and depthwise-separable blocks, a decoder of 3x3 convolutions on the
// upsampled, concatenated features. Provisional until the model issue ships the network.
std::vector<Shape> default_shapes() {
  std::vector<Shape> s;
  s.push_back(make_shape("conv3x3 32->32", false, 120, 160, 32, 32, 3, 1, 1, false));
  s.push_back(make_shape("stem conv3x3 s2 4->24", false, 120, 160, 4, 24, 3, 2, 1, true));
  s.push_back(make_shape("dw3x3 s2 24", true, 60, 80, 24, 24, 3, 2, 1, true));
  s.push_back(make_shape("pw 24->48", false, 30, 40, 24, 48, 1, 1, 1, true));
  s.push_back(make_shape("dw3x3 48", true, 30, 40, 48, 48, 3, 1, 1, true));
  s.push_back(make_shape("pw 48->48", false, 30, 40, 48, 48, 1, 1, 1, true));
  s.push_back(make_shape("dw3x3 s2 48", true, 30, 40, 48, 48, 3, 2, 1, true));
  s.push_back(make_shape("pw 48->96", false, 15, 20, 48, 96, 1, 1, 1, true));
  s.push_back(make_shape("dw3x3 d2 96", true, 15, 20, 96, 96, 3, 1, 2, true));
  s.push_back(make_shape("pw 96->96", false, 15, 20, 96, 96, 1, 1, 1, true));
  s.push_back(make_shape("pw 96->48", false, 15, 20, 96, 48, 1, 1, 1, true));
  s.push_back(make_shape("conv3x3 96->48", false, 30, 40, 96, 48, 3, 1, 1, true));
  s.push_back(make_shape("conv3x3 72->32", false, 60, 80, 72, 32, 3, 1, 1, true));
  s.push_back(make_shape("pw 32->14", false, 60, 80, 32, 14, 1, 1, 1, true));
  return s;
}

// The distinct convolution shapes of a .efm model (weights are still random: speed does not depend on
// them): layers of the same geometry are timed once, named "L24,28,32,36 ..." and counted that many
// times in the per-frame total.
bool model_shapes(const std::string& path, std::vector<Shape>* out) {
  using ef::nn::LayerType;
  ef::Result<ef::nn::Model> model = ef::nn::load_model(path);
  if (!model) {
    std::fprintf(stderr, "bench_nn_conv: %s\n", ef::to_string(model.error()).c_str());
    return false;
  }
  const ef::nn::ModelDesc& d = model->desc;
  for (std::size_t i = 0; i < d.layers.size(); ++i) {
    const ef::nn::LayerDesc& l = d.layers[i];
    if (l.type != LayerType::kConv2d && l.type != LayerType::kDepthwiseConv2d &&
        l.type != LayerType::kPointwiseConv2d)
      continue;
    const ef::nn::TensorDesc& in = d.tensors[l.inputs[0]];
    const ef::nn::TensorDesc& o = d.tensors[l.output];
    Shape s;
    s.depthwise = l.type == LayerType::kDepthwiseConv2d;
    s.in_model = true;
    s.in_h = int(in.h), s.in_w = int(in.w), s.in_c = int(in.c), s.out_c = int(o.c);
    s.kernel_h = int(l.kernel_h), s.kernel_w = int(l.kernel_w);
    s.stride_h = int(l.stride_h), s.stride_w = int(l.stride_w);
    s.dilation_h = int(l.dilation_h), s.dilation_w = int(l.dilation_w);
    s.pad_top = int(l.pad_top), s.pad_left = int(l.pad_left);
    s.pad_bottom = int(l.pad_bottom), s.pad_right = int(l.pad_right);
    if (l.type == LayerType::kPointwiseConv2d) {  // 1 x 1, stride 1, no padding, whatever the unused fields say
      s.kernel_h = s.kernel_w = s.stride_h = s.stride_w = s.dilation_h = s.dilation_w = 1;
      s.pad_top = s.pad_left = s.pad_bottom = s.pad_right = 0;
    }
    if (s.out_h() != int(o.h) || s.out_w() != int(o.w)) {
      std::fprintf(stderr, "bench_nn_conv: %s: layer %zu: output %ux%u, expected %dx%d from its padding; skipped\n",
                   path.c_str(), i, o.h, o.w, s.out_h(), s.out_w());
      continue;
    }
    const char* kind = s.depthwise ? "dw" : l.type == LayerType::kPointwiseConv2d ? "pw" : "conv";
    char what[96];
    std::snprintf(what, sizeof what, " %s%dx%d s%d d%d %d->%d @%dx%d", kind, s.kernel_h, s.kernel_w, s.stride_h,
                  s.dilation_h, s.in_c, s.out_c, s.in_h, s.in_w);
    auto same = std::find_if(out->begin(), out->end(),
                             [&](const Shape& e) { return e.in_model && e.same_geometry(s); });
    if (same != out->end()) {  // "L24 pw..." -> "L24,28 pw..."
      same->name.insert(same->name.find(' '), "," + std::to_string(i));
      ++same->count;
      continue;
    }
    s.name = "L" + std::to_string(i) + what;
    out->push_back(s);
  }
  return true;
}

// ---------------------------------------------------------------------------------------------------
// Int8 peaks.

struct PeakLoop {
  Isa isa;
  bool primary;  // the instruction our kernels of this ISA use for int8 MACs: the "peak" of the ISA
  const char* what;
  int macs_per_instruction;
  int32_t (*fn)(int64_t iters);
};

#if defined(__x86_64__)
const PeakLoop kPeakLoops[] = {
    {Isa::sse41, true, "pmaddwd xmm + paddd", 8, ef::bench::peak_madd_epi16__sse41},
    {Isa::avx2, true, "vpmaddwd ymm + vpaddd", 16, ef::bench::peak_madd_epi16__avx2},
    {Isa::avx2, false, "vpmaddubsw ymm + vpaddw (int16 saturates: reference only)", 32,
     ef::bench::peak_maddubs_epi16__avx2},
    {Isa::avxvnni, true, "vpdpbusd ymm (VEX)", 32, ef::bench::peak_dpbusd__avxvnni},
    {Isa::avx512vnni, true, "vpdpbusd zmm", 64, ef::bench::peak_dpbusd__avx512vnni},
    {Isa::avx512vnni, false, "vpmaddwd zmm + vpaddd (XNNPACK avx512skx's MAC: reference)", 32,
     ef::bench::peak_madd_epi16__avx512vnni},
};
#elif defined(__aarch64__)
const PeakLoop kPeakLoops[] = {
    {Isa::neon, true, "smlal v.8h", 8, ef::bench::peak_smlal__neon},
    {Isa::neondot, true, "sdot v.4s", 16, ef::bench::peak_sdot__neondot},
};
#endif

constexpr int kNumIsas = int(Isa::neondot) + 1;

struct Peaks {
  double gmacs[kNumIsas] = {};  // primary loop per ISA; 0: not measured
  Isa best = Isa::scalar;       // highest ISA measured
  double of(Isa isa) const { return gmacs[int(isa)]; }
};

Peaks measure_peaks(int reps, double min_ms) {
  Peaks p;
  std::printf("\nInt8 peak of each ISA level (%d independent accumulators, fastest of %d runs)\n",
              ef::bench::kPeakChains, reps);
#if defined(__x86_64__) || defined(__aarch64__)
  for (const PeakLoop& l : kPeakLoops) {
    if (!ef::kernels::isa_available(l.isa)) {
      std::printf("  %-11s %-58s skipped (%s)\n", ef::kernels::isa_name(l.isa), l.what,
                  ef::kernels::isa_available(l.isa, ef::detected_cpu_features()) ? "capped by EF_ISA"
                                                                                 : "not available on this CPU");
      continue;
    }
    const int64_t iters = 4096;
    volatile int32_t sink = 0;
    const Timing t = time_calls([&] { sink = l.fn(iters); }, reps, min_ms);
    const double gmacs = double(iters) * ef::bench::kPeakChains * l.macs_per_instruction / t.best * 1e-9;
    std::printf("  %-11s %-58s %8.1f GMAC/s%s\n", ef::kernels::isa_name(l.isa), l.what, gmacs,
                l.primary ? "  <- peak" : "");
    if (l.primary) {
      p.gmacs[int(l.isa)] = gmacs;
      if (int(l.isa) > int(p.best)) p.best = l.isa;
    }
  }
#else
  std::printf("  no peak loops for this architecture\n");
#endif
  return p;
}

// ---------------------------------------------------------------------------------------------------
// XNNPACK.

#if defined(EF_HAVE_XNNPACK)
// The entry points used, so that the linked library and a dlmopen'ed copy run the same code.
struct XnnApi {
  std::string label;  // "XNNPACK", "XNNPACK@avx2"
  Isa peak_isa = Isa::scalar;  // the peak its fraction is quoted against
  decltype(&xnn_initialize) initialize = nullptr;
  decltype(&xnn_create_convolution2d_nhwc_qc8) create = nullptr;
  decltype(&xnn_setup_convolution2d_nhwc_qc8) setup = nullptr;
  decltype(&xnn_run_operator) run = nullptr;
  decltype(&xnn_delete_operator) destroy = nullptr;
};

#if defined(EF_HAVE_CPUINFO) && defined(__x86_64__)
// Clears the cpuinfo flags above `features` (XNNPACK reads cpuinfo_isa once, in xnn_initialize).
void cap_cpuinfo(cpuinfo_x86_isa* isa, const ef::CpuFeatures& features) {
  if (!features.avx512vnni) {
    isa->avx512f = isa->avx512pf = isa->avx512er = isa->avx512cd = isa->avx512dq = isa->avx512bw = false;
    isa->avx512vl = isa->avx512ifma = isa->avx512vbmi = isa->avx512vbmi2 = isa->avx512bitalg = false;
    isa->avx512vpopcntdq = isa->avx512vnni = isa->avx512bf16 = isa->avx512vp2intersect = false;
    isa->avx512_4vnniw = isa->avx512_4fmaps = false;
  }
  if (!features.avx2) isa->avx2 = isa->fma3 = isa->fma4 = isa->xop = isa->avx = isa->f16c = false;
  if (!features.sse41) isa->sse4_1 = isa->sse4_2 = isa->ssse3 = false;  // SSE2: XNNPACK's minimum
}
const char* cpuinfo_level(const cpuinfo_x86_isa& isa) {
  if (isa.avx512f && isa.avx512bw && isa.avx512dq && isa.avx512vl) return "AVX-512";
  if (isa.avx2) return "AVX2";
  if (isa.sse4_1) return "SSE4.1";
  return "SSE2";
}
#endif

// The linked library, its instruction set capped at EF_ISA (as our kernels are).
bool init_xnnpack(XnnApi* api) {
  *api = {"XNNPACK", Isa::scalar, xnn_initialize, xnn_create_convolution2d_nhwc_qc8,
          xnn_setup_convolution2d_nhwc_qc8, xnn_run_operator, xnn_delete_operator};
  std::string level = "uncapped: no cpuinfo.h in this build";
#if defined(EF_HAVE_CPUINFO) && defined(__x86_64__)
  if (cpuinfo_initialize()) {
    cap_cpuinfo(&cpuinfo_isa, ef::cpu_features());
    level = std::string("cpuinfo reports ") + cpuinfo_level(cpuinfo_isa);
  }
#endif
  const xnn_status st = api->initialize(nullptr);
  if (st != xnn_status_success) {
    std::printf("XNNPACK: xnn_initialize failed (status %d); timing our kernels only\n", int(st));
    return false;
  }
  std::printf("XNNPACK: qc8 convolution operators (int8, per-channel weight scales, fp32 requantisation), no "
              "thread pool; %s\n", level.c_str());
  return true;
}

// A second, independent copy of the library (its own cpuinfo and globals) capped at AVX2, for the
// AVX2-path comparison. False where it is not needed (the first copy is at most AVX2) or not possible.
bool init_xnnpack_avx2(XnnApi* api) {
#if defined(EF_HAVE_CPUINFO) && defined(__x86_64__)
  if (!cpuinfo_initialize() || !cpuinfo_isa.avx512f) return false;  // the first copy is the AVX2 one
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  std::printf("XNNPACK@avx2: not under a sanitizer (a second copy of libc in one process); the AVX2 path is "
              "compared with XNNPACK\n");
  return false;
#endif
  void* lib = dlmopen(LM_ID_NEWLM, EF_XNNPACK_PATH, RTLD_NOW | RTLD_LOCAL);  // never closed
  if (!lib) {
    std::printf("XNNPACK@avx2: dlmopen(%s) failed: %s; the AVX2 path is compared with XNNPACK\n", EF_XNNPACK_PATH,
                dlerror());
    return false;
  }
  auto* copy_cpuinfo_initialize = reinterpret_cast<bool (*)()>(dlsym(lib, "cpuinfo_initialize"));
  auto* copy_isa = static_cast<cpuinfo_x86_isa*>(dlsym(lib, "cpuinfo_isa"));
  api->label = "XNNPACK@avx2";
  api->initialize = reinterpret_cast<decltype(api->initialize)>(dlsym(lib, "xnn_initialize"));
  api->create = reinterpret_cast<decltype(api->create)>(dlsym(lib, "xnn_create_convolution2d_nhwc_qc8"));
  api->setup = reinterpret_cast<decltype(api->setup)>(dlsym(lib, "xnn_setup_convolution2d_nhwc_qc8"));
  api->run = reinterpret_cast<decltype(api->run)>(dlsym(lib, "xnn_run_operator"));
  api->destroy = reinterpret_cast<decltype(api->destroy)>(dlsym(lib, "xnn_delete_operator"));
  if (!copy_cpuinfo_initialize || !copy_isa || !api->initialize || !api->create || !api->setup || !api->run ||
      !api->destroy || !copy_cpuinfo_initialize()) {
    std::printf("XNNPACK@avx2: symbols missing in the second copy; the AVX2 path is compared with XNNPACK\n");
    return false;
  }
  ef::CpuFeatures avx2 = ef::cpu_features();
  ef::cap_cpu_features(avx2, "avx2");
  cap_cpuinfo(copy_isa, avx2);
  if (api->initialize(nullptr) != xnn_status_success) {
    std::printf("XNNPACK@avx2: xnn_initialize failed in the second copy; the AVX2 path is compared with XNNPACK\n");
    return false;
  }
  std::printf("XNNPACK@avx2: a second copy of the library (dlmopen), cpuinfo capped: reports %s\n",
              cpuinfo_level(*copy_isa));
  return true;
#else
  (void)api;
  return false;
#endif
}
#endif  // EF_HAVE_XNNPACK

// ---------------------------------------------------------------------------------------------------
// One shape.

// A table of one family and the rows the executor would select.
struct Family {
  const Variant* rows;
  std::size_t count;
  const Variant* simd_path;  // selected with the CPU capped at kSimdPathIsa
  const Variant* best_path;  // selected as detected (and capped by EF_ISA)
};

#if defined(__aarch64__)
constexpr const char* kSimdPathIsa = "neon";
#else
constexpr const char* kSimdPathIsa = "avx2";
#endif

template <std::size_t N>
Family make_family(const Variant (&table)[N]) {
  ef::CpuFeatures capped = ef::cpu_features();
  ef::cap_cpu_features(capped, kSimdPathIsa);
  return {table, N, &ef::kernels::best_variant(table, capped), &ef::kernels::best_variant(table, ef::cpu_features())};
}

struct ShapeResult {
  std::string name;
  bool in_model = false, provisional = false;
  int count = 1;  // model layers of this shape
  double macs = 0;
  double xnn_s = 0, xnn_simd_s = 0;  // XNNPACK, and the one the SIMD path is compared with; 0: none
  double simd_s = 0, best_s = 0;     // our AVX2 (NEON) path and best path
  double best_fraction = 0;          // best path's GMAC/s over its ISA's peak (0: none)
};

// Random int8 data with realistic quantisation: full-range input, roughly normal weights (sigma 40 of
// 127), per-channel weight scales, a bias within one accumulator standard deviation, and scales
// chosen so that the outputs have a standard deviation near 40 (some saturation, mostly in range).
struct LayerData {
  static constexpr float kInScale = 0.02f, kOutScale = 0.05f;
  static constexpr int32_t kInZeroPoint = -3, kOutZeroPoint = 4;
  std::vector<int8_t> weights;
  std::vector<int32_t> bias;
  std::vector<float> weight_scales;
  std::vector<ef::nn::Requant> requant;
};

LayerData make_layer_data(const Shape& s, std::mt19937& rng) {
  LayerData d;
  const std::size_t taps = std::size_t(s.kernel_h) * s.kernel_w * (s.depthwise ? 1 : s.in_c);
  d.weights.resize(taps * s.out_c);
  std::normal_distribution<float> normal(0.0f, 40.0f);
  for (auto& w : d.weights) w = int8_t(std::clamp(std::lround(normal(rng)), -127L, 127L));
  const double acc_sigma = std::sqrt(double(taps)) * 73.9 * 40.0;  // uniform int8 x N(0, 40)
  const double target_multiplier = 40.0 / acc_sigma;
  std::uniform_real_distribution<double> spread(0.75, 1.25);
  std::uniform_int_distribution<int32_t> bias(-int32_t(acc_sigma), int32_t(acc_sigma));
  for (int c = 0; c < s.out_c; ++c) {
    const float w_scale = float(target_multiplier * LayerData::kOutScale / LayerData::kInScale * spread(rng));
    d.weight_scales.push_back(w_scale);
    // As XNNPACK's qc8 operators compute it, in float: the same multiplier, so the same bytes.
    d.requant.push_back({LayerData::kInScale * w_scale / LayerData::kOutScale});
    d.bias.push_back(bias(rng));
  }
  return d;
}

// The index of the first byte where `got` differs from `want` (-1: none); `count` of them.
long first_difference(const int8_t* got, const int8_t* want, std::size_t n, std::size_t* count) {
  long first = -1;
  *count = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (got[i] != want[i]) {
      if (first < 0) first = long(i);
      ++*count;
    }
  return first;
}

constexpr std::size_t kGuardBytes = 64;  // after the output: a kernel that writes past its end is caught
constexpr uint8_t kGuardByte = 0xA5;

// One result line; `vs_s` / `vs` the XNNPACK time and label the ratio is quoted against (none: 0).
void print_line(const char* name, const char* isa, const Timing& t, double macs, double peak, const char* peak_isa,
                double vs_s, const char* vs) {
  const double gmacs = macs / t.median * 1e-9;
  std::printf("  %-26s %-10s %9.1f us %7.2f GMAC/s  iqr %4.1f%%", name, isa, t.median * 1e6, gmacs, 100.0 * t.iqr);
  if (peak > 0)
    std::printf("  %5.1f%% of %-10s peak", 100.0 * gmacs / peak, peak_isa);
  else
    std::printf("  %25s", "");
  if (vs_s > 0) std::printf("  %5.2fx %s", vs_s / t.median, vs);
  std::printf("\n");
}

struct Context {
  const Peaks* peaks = nullptr;
  int reps = 15;
  double min_ms = 2.0;
#if defined(EF_HAVE_XNNPACK)
  std::vector<XnnApi> xnnpack;  // [0] as configured, [1] (optional) capped at AVX2
#endif
};

#if defined(EF_HAVE_XNNPACK)
// Times one XNNPACK configuration on `sh`; 0 when the operator cannot be made.
double time_xnnpack(const Context& ctx, std::size_t which, const Shape& sh, const LayerData& d, const int8_t* in,
                    int8_t* out, const std::vector<int8_t>& want, double macs) {
  const XnnApi& x = ctx.xnnpack[which];
  const uint32_t groups = sh.depthwise ? uint32_t(sh.in_c) : 1u;
  const std::size_t group_in = sh.depthwise ? 1 : std::size_t(sh.in_c);
  const std::size_t group_out = sh.depthwise ? 1 : std::size_t(sh.out_c);
  // Weights: XNNPACK's [groups][group_out][kh][kw][group_in] is the file layout of both conv
  // ([out_c][kh][kw][in_c]) and depthwise ([c][kh][kw]); padding counts as the input zero point.
  xnn_operator_t op = nullptr;
  xnn_status st = x.create(uint32_t(sh.pad_top), uint32_t(sh.pad_right), uint32_t(sh.pad_bottom),
                           uint32_t(sh.pad_left), uint32_t(sh.kernel_h), uint32_t(sh.kernel_w), uint32_t(sh.stride_h),
                           uint32_t(sh.stride_w), uint32_t(sh.dilation_h), uint32_t(sh.dilation_w), groups, group_in,
                           group_out, std::size_t(sh.in_c), std::size_t(sh.out_c), int8_t(LayerData::kInZeroPoint),
                           LayerData::kInScale, d.weight_scales.data(), d.weights.data(), d.bias.data(),
                           int8_t(LayerData::kOutZeroPoint), LayerData::kOutScale, -128, 127, 0, &op);
  if (st == xnn_status_success)
    st = x.setup(op, 1, std::size_t(sh.in_h), std::size_t(sh.in_w), in, out, nullptr);
  if (st == xnn_status_success) {
    std::memset(out, 0x5A, want.size());
    st = x.run(op, nullptr);
  }
  double seconds = 0;
  if (st != xnn_status_success) {
    std::printf("  %-26s failed (xnn_status %d): no comparison\n", x.label.c_str(), int(st));
  } else {
    std::size_t diff = 0;
    const long first = first_difference(out, want.data(), want.size(), &diff);
    const Timing t = time_calls([&] { x.run(op, nullptr); }, ctx.reps, ctx.min_ms);
    seconds = t.median;
    const std::string label = x.label + (sh.depthwise ? " qc8 dw" : " qc8");
    print_line(label.c_str(), "", t, macs, ctx.peaks->of(x.peak_isa), ef::kernels::isa_name(x.peak_isa), 0, "");
    if (first >= 0)
      std::printf("  %-26s (its output differs from the reference in %zu of %zu bytes, first at %ld)\n", "", diff,
                  want.size(), first);
  }
  if (op) x.destroy(op);
  return seconds;
}
#endif

ShapeResult bench_shape(const Context& ctx, const Shape& sh, const Family& family) {
  ShapeResult r;
  r.name = sh.name;
  r.in_model = sh.in_model;
  r.provisional = sh.provisional;
  r.count = sh.count;
  r.macs = sh.macs();
  const int out_h = sh.out_h(), out_w = sh.out_w();
  std::printf("\n%s%s: %dx%dx%d -> %dx%dx%d, %s %dx%d stride %d,%d dilation %d,%d pad t%d l%d b%d r%d, %.3f MMAC\n",
              sh.provisional ? "[provisional] " : "", sh.name.c_str(), sh.in_h, sh.in_w, sh.in_c, out_h, out_w,
              sh.out_c, sh.depthwise ? "depthwise" : "conv", sh.kernel_h, sh.kernel_w, sh.stride_h, sh.stride_w,
              sh.dilation_h, sh.dilation_w, sh.pad_top, sh.pad_left, sh.pad_bottom, sh.pad_right, r.macs * 1e-6);

  std::mt19937 rng(1234u + unsigned(sh.in_c * 131 + sh.out_c * 7 + sh.in_h));
  const std::size_t in_bytes = std::size_t(sh.in_h) * sh.in_w * sh.in_c;
  const std::size_t out_bytes = std::size_t(out_h) * out_w * sh.out_c;
  // XNNPACK may read up to XNN_EXTRA_BYTES (16) past the input; 64 covers it.
  AlignedBytes input = aligned_bytes(in_bytes + 64);
  auto* in = reinterpret_cast<int8_t*>(input.get());
  for (std::size_t i = 0; i < in_bytes; ++i) in[i] = int8_t(rng());
  const LayerData d = make_layer_data(sh, rng);

  ef::nn::ConvArgs args;
  args.in = {in, sh.in_h, sh.in_w, sh.in_c, LayerData::kInZeroPoint};
  args.kernel_h = sh.kernel_h, args.kernel_w = sh.kernel_w;
  args.stride_h = sh.stride_h, args.stride_w = sh.stride_w;
  args.dilation_h = sh.dilation_h, args.dilation_w = sh.dilation_w;
  args.pad_top = sh.pad_top, args.pad_left = sh.pad_left;
  args.weights = d.weights.data();
  args.bias = d.bias.data();
  args.requant = d.requant.data();

  // The reference bytes.
  std::vector<int8_t> want(out_bytes);
  {
    ef::nn::ConvArgs a = args;
    a.out = {want.data(), out_h, out_w, sh.out_c, LayerData::kOutZeroPoint};
    if (sh.depthwise)
      ef::nn::dwconv2d_i8_ref(a);
    else
      ef::nn::conv2d_i8_ref(a);
  }
  AlignedBytes output = aligned_bytes(out_bytes + kGuardBytes);
  auto* out = reinterpret_cast<int8_t*>(output.get());
  args.out = {out, out_h, out_w, sh.out_c, LayerData::kOutZeroPoint};

  // XNNPACK, as configured and (where there is one) capped at AVX2.
  std::string simd_vs = "XNNPACK";
#if defined(EF_HAVE_XNNPACK)
  for (std::size_t i = 0; i < ctx.xnnpack.size(); ++i) {
    const double s = time_xnnpack(ctx, i, sh, d, in, out, want, r.macs);
    if (i == 0) r.xnn_s = r.xnn_simd_s = s;
    if (i == 1 && s > 0) r.xnn_simd_s = s, simd_vs = ctx.xnnpack[1].label;
  }
#endif

  // Ours.
  const ef::nn::ConvShape cs{sh.in_c, sh.out_c, sh.kernel_h, sh.kernel_w, LayerData::kInZeroPoint};
  const ef::nn::ConvParams params{d.weights.data(), d.bias.data(), d.requant.data()};
  for (std::size_t i = 0; i < family.count; ++i) {
    const Variant& v = family.rows[i];
    if (!ef::kernels::isa_available(v.isa)) {
      const bool on_cpu = ef::kernels::isa_available(v.isa, ef::detected_cpu_features());
      std::printf("  %-26s %-10s skipped (%s)\n", v.name, ef::kernels::isa_name(v.isa),
                  on_cpu ? "capped by EF_ISA" : "not available on this CPU");
      continue;
    }
    const ef::nn::ConvKernel& k = *v.fn;
    const std::size_t packed_size = k.packed_bytes(cs);
    AlignedBytes packed = aligned_bytes(packed_size);
    k.pack(cs, params, packed.get());
    ef::nn::ConvArgs a = args;
    a.packed = packed_size ? packed.get() : nullptr;

    // Correctness first: every byte, and nothing written past the end.
    std::memset(out, 0x5A, out_bytes);
    std::memset(out + out_bytes, kGuardByte, kGuardBytes);
    k.run(a);
    std::size_t diff = 0;
    const long first = first_difference(out, want.data(), out_bytes, &diff);
    std::size_t guard_hit = 0;  // 1 + the last guard byte written (0: none)
    for (std::size_t g = 0; g < kGuardBytes; ++g)
      if (uint8_t(out[out_bytes + g]) != kGuardByte) guard_hit = g + 1;
    const bool guard_ok = guard_hit == 0;
    if (first >= 0 || !guard_ok) {
      std::fflush(stdout);
      if (first >= 0) {
        const long px = first / sh.out_c;
        std::fprintf(stderr,
                     "bench_nn_conv: FATAL: %s on \"%s\": output differs from the reference in %zu of %zu bytes; "
                     "first at y %ld x %ld c %ld: got %d, want %d\n",
                     v.name, sh.name.c_str(), diff, out_bytes, px / out_w, px % out_w, first % sh.out_c,
                     int(out[first]), int(want[std::size_t(first)]));
      }
      if (!guard_ok)
        std::fprintf(stderr, "bench_nn_conv: FATAL: %s on \"%s\": wrote past the end of the output (%zu bytes, "
                     "up to byte %zu after it)\n", v.name, sh.name.c_str(), out_bytes, guard_hit);
      std::abort();
    }

    const Timing t = time_calls([&] { k.run(a); }, ctx.reps, ctx.min_ms);
    const bool simd_tier = v.isa == Isa::scalar || v.isa == Isa::sse41 || v.isa == Isa::avx2 || v.isa == Isa::neon;
    print_line(v.name, ef::kernels::isa_name(v.isa), t, r.macs, ctx.peaks->of(v.isa), ef::kernels::isa_name(v.isa),
               simd_tier ? r.xnn_simd_s : r.xnn_s, simd_tier ? simd_vs.c_str() : "XNNPACK");
    if (&v == family.simd_path) r.simd_s = t.median;
    if (&v == family.best_path) {
      r.best_s = t.median;
      r.best_fraction = ctx.peaks->of(v.isa) > 0 ? r.macs / t.median * 1e-9 / ctx.peaks->of(v.isa) : 0;
    }
  }
  if (r.xnn_s > 0)
    std::printf("  => %s path (%s): %.2fx %s; best path (%s): %.2fx XNNPACK\n", kSimdPathIsa, family.simd_path->name,
                r.xnn_simd_s / r.simd_s, simd_vs.c_str(), family.best_path->name, r.xnn_s / r.best_s);
  return r;
}

void print_summary(const std::vector<ShapeResult>& results, const char* simd_vs) {
  const bool any_xnnpack = std::any_of(results.begin(), results.end(), [](const ShapeResult& r) { return r.xnn_s > 0; });
  if (any_xnnpack)
    std::printf("\nSummary: GMAC/s on one thread; ratio = ours / XNNPACK (the %s path against %s, the best path "
                "against XNNPACK); goal >= 1.00x on every shape\n", kSimdPathIsa, simd_vs);
  else
    std::printf("\nSummary: GMAC/s on one thread (no XNNPACK figures)\n");
  std::printf("  %-40s %8s %8s %12s   %-16s %-16s %s\n", "shape", "MMAC", "XNNPACK", simd_vs == std::string("XNNPACK")
              ? "-" : simd_vs, (std::string(kSimdPathIsa) + " path").c_str(), "best path", "best %peak");
  double xnn_total = 0, xnn_simd_total = 0, simd_total = 0, best_total = 0;
  int n_model = 0, simd_met = 0, best_met = 0, compared = 0;
  for (const ShapeResult& r : results) {
    const bool have = r.xnn_s > 0 && r.xnn_simd_s > 0;
    char xnn[24] = "-", xnn_simd[24] = "-", simd[32], best[32], frac[16] = "-";
    if (have) {
      std::snprintf(xnn, sizeof xnn, "%.2f", r.macs / r.xnn_s * 1e-9);
      if (r.xnn_simd_s != r.xnn_s) std::snprintf(xnn_simd, sizeof xnn_simd, "%.2f", r.macs / r.xnn_simd_s * 1e-9);
      std::snprintf(simd, sizeof simd, "%.2f %.2fx", r.macs / r.simd_s * 1e-9, r.xnn_simd_s / r.simd_s);
      std::snprintf(best, sizeof best, "%.2f %.2fx", r.macs / r.best_s * 1e-9, r.xnn_s / r.best_s);
      ++compared;
      simd_met += r.xnn_simd_s / r.simd_s >= 1.0;
      best_met += r.xnn_s / r.best_s >= 1.0;
    } else {
      std::snprintf(simd, sizeof simd, "%.2f", r.macs / r.simd_s * 1e-9);
      std::snprintf(best, sizeof best, "%.2f", r.macs / r.best_s * 1e-9);
    }
    if (r.best_fraction > 0) std::snprintf(frac, sizeof frac, "%.1f%%", 100.0 * r.best_fraction);
    std::printf("  %-40s %8.3f %8s %12s   %-16s %-16s %-6s%s\n", r.name.c_str(), r.macs * 1e-6, xnn, xnn_simd, simd,
                best, frac, r.provisional ? "  [provisional]" : "");
    if (r.in_model) {
      n_model += r.count;
      xnn_total += r.count * r.xnn_s, xnn_simd_total += r.count * r.xnn_simd_s;
      simd_total += r.count * r.simd_s, best_total += r.count * r.best_s;
    }
  }
  if (n_model > 0) {
    std::printf("  model convolutions, one frame (%d layers): ", n_model);
    if (xnn_total > 0 && xnn_simd_total > 0) {
      std::printf("XNNPACK %.3f ms", xnn_total * 1e3);
      if (std::string(simd_vs) != "XNNPACK") std::printf(", %s %.3f ms", simd_vs, xnn_simd_total * 1e3);
      std::printf("; %s path %.3f ms (%.2fx), best path %.3f ms (%.2fx)\n", kSimdPathIsa, simd_total * 1e3,
                  xnn_simd_total / simd_total, best_total * 1e3, xnn_total / best_total);
    } else {
      std::printf("%s path %.3f ms, best path %.3f ms\n", kSimdPathIsa, simd_total * 1e3, best_total * 1e3);
    }
  }
  if (compared > 0)
    std::printf("  goal >= 1.0x: %s path on %d of %d shapes, best path on %d of %d shapes\n", kSimdPathIsa, simd_met,
                compared, best_met, compared);
}

int usage() {
  std::fprintf(stderr, "usage: bench_nn_conv [--reps R] [--min-ms T] [--shape SUBSTR] [--model FILE.efm]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  Context ctx;
  std::string filter, model_path;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (i + 1 >= argc) return usage();
    if (arg == "--reps") ctx.reps = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--min-ms") ctx.min_ms = std::max(0.0, std::atof(argv[++i]));
    else if (arg == "--shape") filter = argv[++i];
    else if (arg == "--model") model_path = argv[++i];
    else return usage();
  }

  std::printf("bench_nn_conv: CPU features: %s (detected: %s); one thread; thread CPU time, median of %d runs of "
              ">= %.1f ms\n", ef::cpu_features().describe().c_str(), ef::detected_cpu_features().describe().c_str(),
              ctx.reps, ctx.min_ms);
  cpu_set_t allowed;
  if (sched_getaffinity(0, sizeof allowed, &allowed) == 0 && CPU_COUNT(&allowed) > 1)
    std::printf("note: this process may run on %d CPUs; pin it (taskset -c 1) for stable numbers\n",
                CPU_COUNT(&allowed));

  const char* simd_vs = "XNNPACK";
#if defined(EF_HAVE_XNNPACK)
  XnnApi api;
  if (init_xnnpack(&api)) {
    ctx.xnnpack.push_back(api);
    XnnApi capped;
    if (init_xnnpack_avx2(&capped)) {
      ctx.xnnpack.push_back(capped);
      simd_vs = "XNNPACK@avx2";
    }
  }
#else
  std::printf("XNNPACK: absent from this build (install libxnnpack-dev and libpthreadpool-dev for the target, "
              "then reconfigure); timing our kernels only\n");
#endif

  std::vector<Shape> shapes;
  if (!model_path.empty()) {
    shapes.push_back(default_shapes().front());
    if (!model_shapes(model_path, &shapes)) return 1;
    int layers = 0;
    for (const Shape& sh : shapes) layers += sh.in_model ? sh.count : 0;
    std::printf("Shapes: 3x3 32->32 at 120x160 and the %zu distinct convolution shapes of %s (%d layers)\n",
                shapes.size() - 1, model_path.c_str(), layers);
  } else {
    shapes = default_shapes();
    std::printf("Shapes: 3x3 32->32 at 120x160 and a PROVISIONAL list of the planned segmentation model's "
                "convolutions (input 120x160x4), marked [provisional]; --model FILE.efm takes a real model's\n");
  }

  const Peaks peaks = measure_peaks(ctx.reps, ctx.min_ms);
  ctx.peaks = &peaks;
#if defined(EF_HAVE_XNNPACK)
  // XNNPACK's fraction of peak: of the best ISA measured; the AVX2-capped copy's, of AVX2's.
  if (!ctx.xnnpack.empty()) ctx.xnnpack[0].peak_isa = peaks.best;
  if (ctx.xnnpack.size() > 1) ctx.xnnpack[1].peak_isa = Isa::avx2;
#endif
  const Family conv = make_family(ef::nn::kConvI8Variants);
  const Family dwconv = make_family(ef::nn::kDwConvI8Variants);
  std::vector<ShapeResult> results;
  for (const Shape& sh : shapes) {
    if (!filter.empty() && sh.name.find(filter) == std::string::npos) continue;
    results.push_back(bench_shape(ctx, sh, sh.depthwise ? dwconv : conv));
  }
  print_summary(results, simd_vs);
  // XNNPACK is not deinitialised: its operators are gone, and the process ends here.
  return 0;
}
