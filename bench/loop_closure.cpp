// The cost of one loop closure's deformation at map sizes of 100,000 and 1,000,000 surfels (issue 30):
// DeformationGraph build (nodes sampled from the pool, 1 per 5000 surfels), optimise (3 Gauss-Newton
// steps, banded Cholesky) with a closure's constraints, and apply (every surfel's position and
// normal). The map: surfels along a 30 m camera path (init_time = last_seen = the frame that saw them), 10 cm
// around it; the constraints: 300 points of the path's last frames moved by 3 cm and 1 degree
// (what a closure corrects), 300 of its first frames pinned, as the SLAM makes them. The path is
// walked in 54,000 frames (30 minutes at 30 Hz: the default mapping.pose_history), and the pose
// history of all of them is corrected too (PoseHistory::deform: each camera pose moved with the map).
//   bench_loop_closure [--reps R]
// Prints the median over R runs (default 7) of each part, in thread CPU ms, for each size. Pin the CPU
// (taskset -c 1); one thread.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <vector>

#include "bench_timing.h"
#include "slam/deformation_graph.h"
#include "slam/pose_history.h"
#include "slam/surfel_pool.h"

namespace {

using ef::slam::DeformationGraph;
using ef::slam::DeformationGraphOptions;
using ef::slam::DeformationResult;
using ef::slam::PoseHistory;
using ef::slam::SurfelPool;

Eigen::Vector3f path_point(float f) { return {0.01f * f, 0.5f * std::sin(0.004f * f), 1.0f + 0.2f * std::cos(0.003f * f)}; }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  int reps = 7;
  for (int i = 1; i + 1 < argc; i += 2)
    if (std::strcmp(argv[i], "--reps") == 0) reps = std::max(1, std::atoi(argv[i + 1]));
  constexpr int kFrames = 3000;      // path samples (the path_point parameter)
  constexpr int kTimeScale = 18;     // frames per path sample: 54,000 frames in all
  constexpr int kHistory = kFrames * kTimeScale;
  auto history = PoseHistory::create(kHistory);
  if (!history.ok()) return 1;
  std::printf("| surfels | nodes | constraints | build ms | optimise ms | apply ms | %d poses ms | total ms | "
              "RMS before -> after, mm |\n", kHistory);
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (int64_t n : {int64_t{100'000}, int64_t{1'000'000}}) {
    ef::slam::SurfelPoolOptions po;
    po.capacity = n;
    auto pool = SurfelPool::create(po);
    if (!pool.ok()) return 1;
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-0.1f, 0.1f);
    for (int64_t i = 0; i < n; ++i) {
      const int f = static_cast<int>(i * kFrames / n);
      const Eigen::Vector3f p = path_point(static_cast<float>(f)) + Eigen::Vector3f(u(rng), u(rng), u(rng));
      pool->append(p.x(), p.y(), p.z(), 0, 0, -1, 0.004f, 10, 0, f * kTimeScale);
    }
    // The pool as SpatialOrder would leave it is grouped by space; along a path that is close to
    // time order, which the sampling above already gives.
    auto graph = DeformationGraph::create(DeformationGraphOptions{}.for_pool(n));
    if (!graph.ok()) return 1;
    const Eigen::AngleAxisf turn(1.0f * static_cast<float>(M_PI) / 180.0f, Eigen::Vector3f::UnitZ());
    std::vector<double> build, opt, apply, poses;
    DeformationResult r;
    std::vector<float> x0(pool->x(), pool->x() + n), y0(pool->y(), pool->y() + n), z0(pool->z(), pool->z() + n);
    for (int rep = 0; rep < reps; ++rep) {
      for (int f = 0; f < kHistory; ++f)
        history->push(f, f / 30.0, ef::SE3(Eigen::Quaterniond::Identity(),
                                           (path_point(static_cast<float>(f) / kTimeScale) - Eigen::Vector3f(0, 0, 1))
                                               .cast<double>()));
      std::copy(x0.begin(), x0.end(), pool->x());
      std::copy(y0.begin(), y0.end(), pool->y());
      std::copy(z0.begin(), z0.end(), pool->z());
      double t = ef::bench::thread_cpu_seconds();
      const auto lap_ms = [&t] {
        const double now = ef::bench::thread_cpu_seconds(), ms = (now - t) * 1e3;
        t = now;
        return ms;
      };
      if (!graph->build(*pool).ok()) return 1;
      build.push_back(lap_ms());
      const Eigen::Vector3f pivot = path_point(kFrames - 10);
      for (int k = 0; k < 300; ++k) {
        const float f_late = kFrames - 30 + 0.1f * k, f_early = 0.1f * k;
        const Eigen::Vector3f v = path_point(f_late) + Eigen::Vector3f(0, 0.05f, 0);
        graph->add_constraint(v, static_cast<int32_t>(f_late * kTimeScale),
                              turn * (v - pivot) + pivot + Eigen::Vector3f(0.03f, 0, 0));
        const Eigen::Vector3f w = path_point(f_early);
        graph->add_constraint(w, static_cast<int32_t>(f_early * kTimeScale), w);
      }
      if (!graph->optimise(&r).ok()) return 1;
      opt.push_back(lap_ms());
      graph->apply(*pool);
      apply.push_back(lap_ms());
      history->deform(*graph);
      poses.push_back(lap_ms());
    }
    const double b = median(build), o = median(opt), a = median(apply), h = median(poses);
    std::printf("| %lld | %d | %d | %.2f | %.2f | %.2f | %.2f | %.2f | %.1f -> %.2f |\n", static_cast<long long>(n),
                graph->nodes(), graph->constraints(), b, o, a, h, b + o + a + h, 1000 * r.rms_before_m,
                1000 * r.rms_after_m);
  }
  return 0;
}
