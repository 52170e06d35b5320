// Times every kernel variant this CPU can run (the same tables the dispatcher and tests use).
//   bench_kernels [--reps R] [--min-ms T]
// Per variant: R timed runs, each repeating the kernel until it has taken at least T ms; prints the
// median time per call and the throughput (depth: GB/s of uint16 input + float output; dot: GOP/s,
// counting one multiply and one add per element pair; normal equations: million rows/s of
// 8-float Gauss-Newton rows; fusion gates and the bilateral filter: million pixels/s of one 320x240
// frame; pyramid rows: million coarse pixels/s of a 160x120 level; normal rows and the prediction's
// gradient and hole rows: million pixels/s of a 320x240 image). Pin the CPU and close other work
// first.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <vector>

#include "kernels/bilateral_row_variants.h"
#include "kernels/depth_u16_to_metres_variants.h"
#include "kernels/dot_i8_variants.h"
#include "kernels/fusion_gates_variants.h"
#include "kernels/gradient_fill_row_variants.h"
#include "kernels/normal_row_variants.h"
#include "kernels/pyramid_row_variants.h"
#include "kernels/reduce_normal_equations_variants.h"
#include "platform/cpu/cpu_features.h"

namespace {

using Clock = std::chrono::steady_clock;

// Median seconds per call of `fn` over `reps` runs of at least `min_ms` each.
template <class F>
double median_seconds_per_call(F&& fn, int reps, double min_ms) {
  std::vector<double> per_call;
  for (int r = 0; r < reps; ++r) {
    long calls = 0;
    const auto t0 = Clock::now();
    double elapsed_ms = 0;
    do {
      fn();
      ++calls;
      elapsed_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    } while (elapsed_ms < min_ms);
    per_call.push_back(elapsed_ms * 1e-3 / static_cast<double>(calls));
  }
  std::sort(per_call.begin(), per_call.end());
  return per_call[per_call.size() / 2];
}

volatile int32_t g_sink;  // keeps dot results alive
volatile double g_sink_f;  // keeps normal-equation results alive

}  // namespace

int main(int argc, char** argv) {
  int reps = 11;
  double min_ms = 20.0;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--reps")) reps = std::max(1, std::atoi(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--min-ms")) min_ms = std::atof(argv[i + 1]);
  }
  using namespace ef::kernels;
  const ef::CpuFeatures& cpu = ef::detected_cpu_features();
  std::printf("CPU features: %s; median of %d runs of >= %.0f ms each\n", cpu.describe().c_str(), reps, min_ms);

  // One 640x480 depth image (TUM scale).
  const std::size_t pixels = 640 * 480;
  std::vector<uint16_t> raw(pixels);
  std::mt19937 rng(1);
  for (auto& r : raw) r = static_cast<uint16_t>(rng() % 20000);
  std::vector<float> metres(pixels);
  std::printf("\ndepth_u16_to_metres, %zu pixels (640x480)\n", pixels);
  for (const auto& v : kDepthU16ToMetresVariants) {
    if (!isa_available(v.isa, cpu)) {
      std::printf("  %-34s skipped (CPU lacks %s)\n", v.name, isa_name(v.isa));
      continue;
    }
    const double s = median_seconds_per_call([&] { v.fn(raw.data(), metres.data(), pixels, 1.0f / 5000.0f, 65535); },
                                             reps, min_ms);
    const double bytes = static_cast<double>(pixels) * (sizeof(uint16_t) + sizeof(float));
    std::printf("  %-34s %9.2f us  %7.2f GB/s\n", v.name, s * 1e6, bytes / s * 1e-9);
  }

  // A 3x3x256 int8 convolution window (2304) and a long vector that still fits in L2 (64 KiB).
  for (std::size_t n : {std::size_t{2304}, std::size_t{65536}}) {
    std::vector<int8_t> a(n), b(n);
    for (auto& x : a) x = static_cast<int8_t>(rng());
    for (auto& x : b) x = static_cast<int8_t>(rng());
    std::printf("\ndot_i8, n = %zu\n", n);
    for (const auto& v : kDotI8Variants) {
      if (!isa_available(v.isa, cpu)) {
        std::printf("  %-34s skipped (CPU lacks %s)\n", v.name, isa_name(v.isa));
        continue;
      }
      const double s = median_seconds_per_call([&] { g_sink = v.fn(a.data(), b.data(), n); }, reps, min_ms);
      std::printf("  %-34s %9.3f us  %7.2f GOP/s\n", v.name, s * 1e6, 2.0 * static_cast<double>(n) / s * 1e-9);
    }
  }
  // Gauss-Newton rows (J, r, w) of one 320x240 frame, and of the coarsest pyramid level (80x60).
  for (std::size_t n : {std::size_t{76800}, std::size_t{4800}}) {
    std::vector<float> rows(8 * n);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (auto& x : rows) x = u(rng);
    for (std::size_t i = 0; i < n; ++i) rows[7 * n + i] = 0.5f * (u(rng) + 1.0f);
    std::printf("\nreduce_normal_equations, n = %zu rows\n", n);
    for (const auto& v : kReduceNormalEquationsVariants) {
      if (!isa_available(v.isa, cpu)) {
        std::printf("  %-34s skipped (CPU lacks %s)\n", v.name, isa_name(v.isa));
        continue;
      }
      NormalEquations ne;
      const double s = median_seconds_per_call([&] { v.fn(rows.data(), n, n, &ne); g_sink_f = ne.upper[0]; }, reps,
                                               min_ms);
      std::printf("  %-34s %9.2f us  %7.1f Mrows/s\n", v.name, s * 1e6, static_cast<double>(n) / s * 1e-6);
    }
  }
  // Fusion's static gates over one 320x240 frame (rows 1..238, pixels 1..318): index rows with a
  // surfel in two of three cells near each pixel's depth.
  {
    constexpr int kW = 320, kH = 240;
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::vector<int32_t> ids(kW * kH);
    std::vector<float> depth(kW * kH), surface(4 * kW * kH), px(7 * kW);
    for (int i = 0; i < kW * kH; ++i) {
      ids[i] = rng() % 3 == 0 ? -1 : static_cast<int32_t>(rng() % 300000);
      depth[i] = 2.0f + 0.05f * u(rng);
      surface[4 * i] = 0.3f * u(rng);
      surface[4 * i + 1] = 0.3f * u(rng);
      surface[4 * i + 2] = -0.9f;
      surface[4 * i + 3] = 10.0f;
    }
    for (int x = 0; x < kW; ++x) {
      px[x] = static_cast<float>(x);      // xi
      px[kW + x] = 0.0f;                  // yi (set per row)
      px[2 * kW + x] = 2.0f;              // z
      px[3 * kW + x] = 0.042f;            // gate
      px[4 * kW + x] = 0.1f * u(rng);     // normal
      px[5 * kW + x] = 0.1f * u(rng);
      px[6 * kW + x] = -0.99f;
    }
    FusionGateRow row;
    row.xi = px.data();
    row.yi = px.data() + kW;
    row.z = px.data() + 2 * kW;
    row.gate = px.data() + 3 * kW;
    row.nwx = px.data() + 4 * kW;
    row.nwy = px.data() + 5 * kW;
    row.nwz = px.data() + 6 * kW;
    std::vector<uint32_t> code(kW);
    std::printf("\nfusion_gates, one %dx%d frame\n", kW, kH);
    for (const auto& v : kFusionGatesVariants) {
      if (!isa_available(v.isa, cpu)) {
        std::printf("  %-34s skipped (CPU lacks %s)\n", v.name, isa_name(v.isa));
        continue;
      }
      const double s = median_seconds_per_call(
          [&] {
            for (int y = 1; y < kH - 1; ++y) {
              FusionGateParams p;
              for (int k = 0; k < 3; ++k) {
                p.id[k] = ids.data() + (y + k - 1) * kW;
                p.depth[k] = depth.data() + (y + k - 1) * kW;
                p.surface[k] = surface.data() + 4 * (y + k - 1) * kW;
              }
              p.pool_size = 300000;
              p.y = y;
              std::fill(px.begin() + kW, px.begin() + 2 * kW, static_cast<float>(y));
              v.fn(p, row, 1, kW - 1, code.data());
              g_sink = static_cast<int32_t>(code[y]);
            }
          },
          reps, min_ms);
      std::printf("  %-34s %9.1f us  %7.1f Mpixels/s\n", v.name, s * 1e6, (kW - 2) * (kH - 2) / s * 1e-6);
    }
  }
  // The depth bilateral filter over one 320x240 frame, radius 2 (the default): a noisy plane.
  {
    constexpr int kW = 320, kH = 240, kR = 2;
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::vector<float> padded((kW + 2 * kR) * (kH + 2 * kR), 1.0e6f), raw_depth(kW * kH), out(kW * kH), spatial(25);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        const float d = 2.0f + 0.01f * u(rng);
        raw_depth[y * kW + x] = d;
        padded[(y + kR) * (kW + 2 * kR) + x + kR] = d;
      }
    for (int k = 0; k < 25; ++k) spatial[k] = 0.5f + 0.02f * static_cast<float>(k);
    std::printf("\nbilateral_row, one %dx%d frame, radius %d\n", kW, kH, kR);
    for (const auto& v : kBilateralRowVariants) {
      if (!isa_available(v.isa, cpu)) {
        std::printf("  %-34s skipped (CPU lacks %s)\n", v.name, isa_name(v.isa));
        continue;
      }
      const double s = median_seconds_per_call(
          [&] {
            const float* rows[2 * kR + 1];
            BilateralRow b;
            b.rows = rows;
            b.spatial = spatial.data();
            b.radius = kR;
            b.k8 = 1.0f / (16.0f * 0.03f * 0.03f);
            for (int y = 0; y < kH; ++y) {
              for (int k = 0; k <= 2 * kR; ++k) rows[k] = padded.data() + (y + k) * (kW + 2 * kR);
              b.raw = raw_depth.data() + y * kW;
              v.fn(b, kW, out.data() + y * kW);
            }
          },
          reps, min_ms);
      std::printf("  %-34s %9.1f us  %7.1f Mpixels/s\n", v.name, s * 1e6, kW * kH / s * 1e-6);
    }
  }
  // One pyramid level of the model prediction: 160x120 coarse pixels, depth and intensity, from a
  // 320x240 noisy plane with 10% holes.
  {
    constexpr int kW = 320, kH = 240, kCw = kW / 2, kCh = kH / 2;
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<float> depth(kW * kH), grey(kW * kH), out_d(kCw * kCh), out_i(kCw * kCh);
    for (int k = 0; k < kW * kH; ++k) {
      depth[k] = u(rng) < 0.1f ? 0.0f : 2.0f + 0.01f * u(rng);
      grey[k] = 255.0f * u(rng);
    }
    std::printf("\npyramid_row, one %dx%d level from %dx%d, depth and intensity\n", kCw, kCh, kW, kH);
    for (const auto& v : kPyramidRowVariants) {
      if (!isa_available(v.isa, cpu)) {
        std::printf("  %-34s skipped (CPU lacks %s)\n", v.name, isa_name(v.isa));
        continue;
      }
      const double s = median_seconds_per_call(
          [&] {
            PyramidRow r;
            r.threshold_m = 0.09f;
            for (int y = 1; y < kCh - 1; ++y) {
              for (int j = 0; j < 4; ++j) {
                r.depth[j] = depth.data() + (2 * y - 1 + j) * kW;
                r.intensity[j] = grey.data() + (2 * y - 1 + j) * kW;
              }
              v.fn(r, 1, kCw - 1, out_d.data() + y * kCw, out_i.data() + y * kCw);
            }
          },
          reps, min_ms);
      std::printf("  %-34s %9.1f us  %7.1f Mpixels/s\n", v.name, s * 1e6, (kCw - 2) * (kCh - 2) / s * 1e-6);
    }
  }
  // The normals of one 320x240 vertex map: a tilted plane at about 2 m.
  {
    constexpr int kW = 320, kH = 240;
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::vector<float> vertex(3 * kW * kH), normal(3 * kW * kH);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        const float d = 2.0f + 0.002f * static_cast<float>(x) + 0.001f * u(rng);
        float* v = &vertex[3 * (y * kW + x)];
        v[0] = (static_cast<float>(x) - 160.0f) * d / 290.0f;
        v[1] = (static_cast<float>(y) - 120.0f) * d / 290.0f;
        v[2] = d;
      }
    std::printf("\nnormal_row, one %dx%d frame\n", kW, kH);
    for (const auto& v : kNormalRowVariants) {
      if (!isa_available(v.isa, cpu)) {
        std::printf("  %-34s skipped (CPU lacks %s)\n", v.name, isa_name(v.isa));
        continue;
      }
      const double s = median_seconds_per_call(
          [&] {
            NormalRow r;
            r.step_x = r.step_y = 11.43f / 290.0f;
            for (int y = 1; y < kH - 1; ++y) {
              for (int k = 0; k < 3; ++k) r.vertex[k] = vertex.data() + 3 * (y - 1 + k) * kW;
              v.fn(r, 1, kW - 1, normal.data() + 3 * y * kW);
            }
          },
          reps, min_ms);
      std::printf("  %-34s %9.1f us  %7.1f Mpixels/s\n", v.name, s * 1e6, (kW - 2) * (kH - 2) / s * 1e-6);
    }
  }
  // The prediction's gradients and filled holes over one 320x240 level: a textured surface, 20% holes.
  {
    constexpr int kW = 320, kH = 240;
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<float> grey(kW * kH), depth(kW * kH), gx(kW * kH), gy(kW * kH), filled(kW);
    for (int k = 0; k < kW * kH; ++k) {
      depth[k] = u(rng) < 0.2f ? 0.0f : 2.0f;
      grey[k] = 255.0f * u(rng);
    }
    std::printf("\ngradient_fill_row, one %dx%d level\n", kW, kH);
    for (const auto& v : kGradientFillRowVariants) {
      if (!isa_available(v.isa, cpu)) {
        std::printf("  %-34s skipped (CPU lacks %s)\n", v.name, isa_name(v.isa));
        continue;
      }
      const double s = median_seconds_per_call(
          [&] {
            GradientFillRow r;
            for (int y = 1; y < kH - 1; ++y) {
              for (int k = 0; k < 3; ++k) {
                r.intensity[k] = grey.data() + (y - 1 + k) * kW;
                r.depth[k] = depth.data() + (y - 1 + k) * kW;
              }
              v.fn(r, 1, kW - 1, gx.data() + y * kW, gy.data() + y * kW, filled.data());
            }
          },
          reps, min_ms);
      std::printf("  %-34s %9.1f us  %7.1f Mpixels/s\n", v.name, s * 1e6, (kW - 2) * (kH - 2) / s * 1e-6);
    }
  }
  return 0;
}
