// Times every variant this CPU can run of the int8 runtime's non-convolution layers (the tables of
// nn/eltwise_kernels.h, as the executor and tests use them) on the shipped network's shapes:
//   upsample bilinear x2   15x20x64 -> 30x40, 30x40x32 -> 60x80, 60x80x14 -> 120x160
//   softmax                120x160x14 (float output)
//   concat                 30x40 64+64 and 60x80 32+32, as copies (inputs in the output's
//                          quantisation) and as requantisations
// and, for completeness, nearest x2 on 60x80x14, avg pool 3x3 s1 p1 on 30x40x128 and clamp on
// 60x80x32; for an imported DeepLabv3 head at a 257 input: resize_bilinear 33x33x151 -> 257x257 (the
// ADE20K logits) and 1x1x256 -> 33x33 (the image pooling broadcast), and the 33x33x320 global
// average pool.
//   bench_nn_ops [--reps R] [--min-ms T] [--cpu-time] [--only NAME]
// Per variant: R timed runs, each repeating the kernel until it has taken at least T ms; prints the
// median nanoseconds per call (wall clock; with --cpu-time this thread's CPU time instead, which
// leaves out the time a loaded machine gives to other processes),  the throughput in GB/s (bytes read + bytes written per call, 1 GB =
// 1e9 bytes; every input byte counted once, so the bilinear taps re-read from cache are not) and the
// speed-up over the reference. One thread. Pin the CPU and close other work first.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <random>
#include <string>
#include <vector>

#include "kernels/variants.h"
#include "nn/eltwise_kernels.h"
#include "platform/cpu/cpu_features.h"

namespace {

using namespace ef::nn;

struct Settings {
  int reps = 11;
  double min_ms = 20.0;
  bool cpu_time = false;     // this thread's CPU time instead of the wall clock
  const char* only = nullptr;  // run only the tables whose title contains this
};

// Milliseconds on the wall clock or on this thread's CPU clock.
double now_ms(bool cpu_time) {
  if (cpu_time) {
    timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
  }
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Median seconds per call of `fn` over `reps` runs of at least `min_ms` each.
template <class F>
double median_seconds_per_call(F&& fn, const Settings& s) {
  std::vector<double> per_call;
  for (int r = 0; r < s.reps; ++r) {
    long calls = 0;
    const double t0 = now_ms(s.cpu_time);
    double elapsed_ms = 0;
    do {
      fn();
      ++calls;
      elapsed_ms = now_ms(s.cpu_time) - t0;
    } while (elapsed_ms < s.min_ms);
    per_call.push_back(elapsed_ms * 1e-3 / static_cast<double>(calls));
  }
  std::sort(per_call.begin(), per_call.end());
  return per_call[per_call.size() / 2];
}

std::vector<int8_t> random_bytes(std::size_t n, std::mt19937& rng) {
  std::vector<int8_t> v(n);
  for (auto& x : v) x = static_cast<int8_t>(rng());
  return v;
}

// Times each runnable row of `table` with `call(fn)`; `bytes` moved per call.
template <class Fn, std::size_t N, class Call>
void time_table(const char* title, const ef::kernels::KernelVariant<Fn> (&table)[N], double bytes, const Settings& s,
                Call&& call) {
  if (s.only && !std::strstr(title, s.only)) return;
  const ef::CpuFeatures& cpu = ef::detected_cpu_features();
  std::printf("\n%s (%.0f KB moved per call)\n", title, bytes / 1024.0);
  double ref_s = 0;
  for (const auto& v : table) {
    if (!ef::kernels::isa_available(v.isa, cpu)) {
      std::printf("  %-34s skipped (CPU lacks %s)\n", v.name, ef::kernels::isa_name(v.isa));
      continue;
    }
    const double sec = median_seconds_per_call([&] { call(v.fn); }, s);
    if (ref_s == 0) ref_s = sec;  // row 0 is the reference
    std::printf("  %-34s %10.0f ns  %7.2f GB/s  %6.1fx\n", v.name, sec * 1e9, bytes / sec * 1e-9, ref_s / sec);
  }
}

void bench_bilinear(int h, int w, int c, const Settings& s, std::mt19937& rng) {
  const std::vector<int8_t> in = random_bytes(std::size_t(h) * w * c, rng);
  std::vector<int8_t> out(in.size() * 4);
  UpsampleArgs a;
  a.in = TensorI8{in.data(), h, w, c, 0};
  a.out = MutTensorI8{out.data(), 2 * h, 2 * w, c, 0};
  a.factor = 2;
  const std::string title = "upsample_bilinear_i8 x2, " + std::to_string(h) + "x" + std::to_string(w) + "x" +
                            std::to_string(c) + " -> " + std::to_string(2 * h) + "x" + std::to_string(2 * w);
  time_table(title.c_str(), kUpsampleBilinearI8Variants, double(in.size() + out.size()), s,
             [&](UpsampleI8Fn fn) { fn(a); });
}

void bench_nearest(int h, int w, int c, const Settings& s, std::mt19937& rng) {
  const std::vector<int8_t> in = random_bytes(std::size_t(h) * w * c, rng);
  std::vector<int8_t> out(in.size() * 4);
  UpsampleArgs a;
  a.in = TensorI8{in.data(), h, w, c, 0};
  a.out = MutTensorI8{out.data(), 2 * h, 2 * w, c, 0};
  a.factor = 2;
  const std::string title = "upsample_nearest_i8 x2, " + std::to_string(h) + "x" + std::to_string(w) + "x" +
                            std::to_string(c) + " -> " + std::to_string(2 * h) + "x" + std::to_string(2 * w);
  time_table(title.c_str(), kUpsampleNearestI8Variants, double(in.size() + out.size()), s,
             [&](UpsampleI8Fn fn) { fn(a); });
}

void bench_softmax(int h, int w, int c, const Settings& s, std::mt19937& rng) {
  const std::vector<int8_t> in = random_bytes(std::size_t(h) * w * c, rng);
  std::vector<float> out(in.size());
  std::vector<float> table(256);
  for (int d = 0; d < 256; ++d) table[d] = static_cast<float>(std::exp(-0.1 * d));  // input scale 0.1
  SoftmaxArgs a;
  a.in = TensorI8{in.data(), h, w, c, 0};
  a.out = out.data();
  a.exp_table = table.data();
  const std::string title =
      "softmax_i8, " + std::to_string(h) + "x" + std::to_string(w) + "x" + std::to_string(c) + " -> float";
  time_table(title.c_str(), kSoftmaxI8Variants, double(in.size() + out.size() * sizeof(float)), s,
             [&](SoftmaxI8Fn fn) { fn(a); });
}

void bench_concat(int h, int w, int c0, int c1, bool copy, const Settings& s, std::mt19937& rng) {
  const std::size_t pixels = std::size_t(h) * w;
  const std::vector<int8_t> in0 = random_bytes(pixels * c0, rng), in1 = random_bytes(pixels * c1, rng);
  std::vector<int8_t> out(pixels * (c0 + c1));
  ConcatArgs a;
  a.count = 2;
  a.in[0] = TensorI8{in0.data(), h, w, c0, copy ? 3 : -7};
  a.in[1] = TensorI8{in1.data(), h, w, c1, copy ? 3 : 12};
  a.rq[0].multiplier = copy ? 1.0f : 0.8125f;
  a.rq[1].multiplier = copy ? 1.0f : 1.375f;
  a.out = MutTensorI8{out.data(), h, w, c0 + c1, 3};
  const std::string title = "concat_i8 " + std::string(copy ? "(copies)" : "(requantised)") + ", " +
                            std::to_string(h) + "x" + std::to_string(w) + " " + std::to_string(c0) + "+" +
                            std::to_string(c1);
  time_table(title.c_str(), kConcatI8Variants, double(in0.size() + in1.size() + out.size()), s,
             [&](ConcatI8Fn fn) { fn(a); });
}

void bench_avgpool(int h, int w, int c, const Settings& s, std::mt19937& rng) {
  const std::vector<int8_t> in = random_bytes(std::size_t(h) * w * c, rng);
  std::vector<int8_t> out(in.size());
  std::vector<Requant> by_count(9);
  for (int n = 1; n <= 9; ++n) by_count[n - 1].multiplier = static_cast<float>(1.0 / n);
  PoolArgs a;
  a.in = TensorI8{in.data(), h, w, c, 2};
  a.out = MutTensorI8{out.data(), h, w, c, -1};
  a.kernel_h = a.kernel_w = 3;
  a.pad_top = a.pad_left = 1;
  a.requant_by_count = by_count.data();
  const std::string title = "avgpool_i8 3x3 s1 p1, " + std::to_string(h) + "x" + std::to_string(w) + "x" +
                            std::to_string(c);
  time_table(title.c_str(), kAvgPoolI8Variants, double(in.size() + out.size()), s, [&](PoolI8Fn fn) { fn(a); });
}

void bench_resize(int h, int w, int c, int oh, int ow, const Settings& s, std::mt19937& rng) {
  const std::vector<int8_t> in = random_bytes(std::size_t(h) * w * c, rng);
  std::vector<int8_t> out(std::size_t(oh) * ow * c);
  std::vector<ResizeTap> taps(std::size_t(oh) + ow);  // as the loader tabulates them
  for (int o = 0; o < oh; ++o) taps[o] = resize_tap(o, h, oh);
  for (int o = 0; o < ow; ++o) taps[oh + o] = resize_tap(o, w, ow);
  ResizeArgs a;
  a.in = TensorI8{in.data(), h, w, c, 0};
  a.out = MutTensorI8{out.data(), oh, ow, c, 0};
  a.taps_y = taps.data();
  a.taps_x = taps.data() + oh;
  const std::string title = "resize_bilinear_i8, " + std::to_string(h) + "x" + std::to_string(w) + "x" +
                            std::to_string(c) + " -> " + std::to_string(oh) + "x" + std::to_string(ow);
  time_table(title.c_str(), kResizeBilinearI8Variants, double(in.size() + out.size()), s,
             [&](ResizeI8Fn fn) { fn(a); });
}

void bench_global_pool(int h, int w, int c, const Settings& s, std::mt19937& rng) {
  const std::vector<int8_t> in = random_bytes(std::size_t(h) * w * c, rng);
  std::vector<int8_t> out(static_cast<std::size_t>(c));
  const Requant rq{static_cast<float>(1.0 / (h * w))};  // the loader's one-entry table
  PoolArgs a;
  a.in = TensorI8{in.data(), h, w, c, 2};
  a.out = MutTensorI8{out.data(), 1, 1, c, -1};
  a.kernel_h = h;
  a.kernel_w = w;
  a.requant_by_count = &rq;
  a.requant_count_base = h * w;
  const std::string title = "avgpool_i8 global, " + std::to_string(h) + "x" + std::to_string(w) + "x" +
                            std::to_string(c);
  time_table(title.c_str(), kAvgPoolI8Variants, double(in.size() + out.size()), s, [&](PoolI8Fn fn) { fn(a); });
}

void bench_clamp(int h, int w, int c, const Settings& s, std::mt19937& rng) {
  const std::vector<int8_t> in = random_bytes(std::size_t(h) * w * c, rng);
  std::vector<int8_t> out(in.size());
  ClampArgs a;
  a.in = TensorI8{in.data(), h, w, c, 0};
  a.out = MutTensorI8{out.data(), h, w, c, 0};
  a.out_min = 0;
  a.out_max = 100;
  const std::string title = "clamp_i8, " + std::to_string(h) + "x" + std::to_string(w) + "x" + std::to_string(c);
  time_table(title.c_str(), kClampI8Variants, double(in.size() + out.size()), s, [&](ClampI8Fn fn) { fn(a); });
}

}  // namespace

int main(int argc, char** argv) {
  Settings s;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--reps") && i + 1 < argc) {
      s.reps = std::max(1, std::atoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--min-ms") && i + 1 < argc) {
      s.min_ms = std::atof(argv[++i]);
    } else if (!std::strcmp(argv[i], "--cpu-time")) {
      s.cpu_time = true;
    } else if (!std::strcmp(argv[i], "--only") && i + 1 < argc) {
      s.only = argv[++i];
    } else {
      std::fprintf(stderr, "usage: bench_nn_ops [--reps R] [--min-ms T] [--cpu-time] [--only NAME]\n");
      return 2;
    }
  }
  std::printf("CPU features: %s; median of %d runs of >= %.0f ms (%s) each; one thread\n",
              ef::detected_cpu_features().describe().c_str(), s.reps, s.min_ms,
              s.cpu_time ? "thread CPU time" : "wall clock");
  std::mt19937 rng(1);
  bench_bilinear(15, 20, 64, s, rng);
  bench_bilinear(30, 40, 32, s, rng);
  bench_bilinear(60, 80, 14, s, rng);
  bench_softmax(120, 160, 14, s, rng);
  bench_concat(30, 40, 64, 64, true, s, rng);
  bench_concat(30, 40, 64, 64, false, s, rng);
  bench_concat(60, 80, 32, 32, true, s, rng);
  bench_concat(60, 80, 32, 32, false, s, rng);
  bench_nearest(60, 80, 14, s, rng);
  bench_avgpool(30, 40, 128, s, rng);
  bench_clamp(60, 80, 32, s, rng);
  bench_resize(33, 33, 151, 257, 257, s, rng);
  bench_resize(1, 1, 256, 33, 33, s, rng);
  bench_global_pool(33, 33, 320, s, rng);
  return 0;
}
