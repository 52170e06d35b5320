// libFuzzer target for TUM trajectory files (io/trajectory_io.h): what `edgefusion eval ate|rpe` reads
// (ground truth and estimate), what --labels-final-out reads back (the run's trajectory.txt, lost
// frames marked), and the loop closure's rewrite of that file in place (rewrite_tum_poses).
// Input: "<ground truth>\0<estimate>" (without a NUL byte, the text is both).
//   1. Both read from in-memory files; when both read, ATE and RPE as `eval` computes them (eval/);
//      the estimate also as the map preview's path (pipeline/map_preview.h read_preview_path).
//   2. The estimate written to a scratch file (tmpfs) and rewritten with every other pose moved, a
//      comment line put in, then rewritten again with the same comment key (the earlier comment is
//      replaced). A file that read back whole (no cut last line) and was rewritten must read back
//      again with as many poses or fewer (timestamps rounded to microseconds may meet): otherwise
//      abort, a finding.
// Any crash, sanitizer report or hang is a bug; an error is the expected answer to a bad file.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "eval/trajectory_eval.h"
#include "fuzz_support.h"
#include "io/trajectory_io.h"
#include "pipeline/map_preview.h"

namespace {

bool shift_every_other(int* count, double /*timestamp*/, ef::SE3* T) {
  if ((*count)++ % 2 != 0) return false;
  *T = ef::SE3(T->rotation(), T->translation() + Eigen::Vector3d(0.01, -0.02, 0.005));
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static ef::fuzz::MemFile gt_file, est_file;
  const uint8_t* nul = static_cast<const uint8_t*>(std::memchr(data, 0, size));
  const std::size_t gt_size = nul != nullptr ? static_cast<std::size_t>(nul - data) : size;
  const uint8_t* est = nul != nullptr ? nul + 1 : data;
  const std::size_t est_size = nul != nullptr ? size - gt_size - 1 : size;

  auto gt = ef::read_tum_trajectory(gt_file.write(data, gt_size));
  auto estimate = ef::read_tum_trajectory(est_file.write(est, est_size));
  if (gt.ok() && estimate.ok()) {
    (void)gt->cut_line_warning();
    (void)estimate->duplicate_warning();
    (void)ef::evaluate_ate(*gt, *estimate);
    (void)ef::evaluate_rpe(*gt, *estimate, 1);
    (void)ef::evaluate_rpe(*gt, *estimate, 3, 0.5);
  }
  // The path `view --trajectory` and the preview draw: a reader of its own (every k-th pose kept).
  (void)ef::pipeline::read_preview_path(est_file.path(), 16);

  const std::string path = (ef::fuzz::scratch_dir() / "trajectory.txt").string();
  ef::fuzz::write_file(path, est, est_size);
  int count = 0;
  auto call = [&count](double t, ef::SE3* T) { return shift_every_other(&count, t, T); };
  auto first = ef::rewrite_tum_poses(path, call, "loop closure: fuzz 1", 13);
  if (!first.ok()) return 0;
  count = 1;
  auto second = ef::rewrite_tum_poses(path, call, "loop closure: fuzz 2", 13);
  if (!second.ok()) {
    std::fprintf(stderr, "a rewritten trajectory cannot be rewritten again: %s\n", ef::to_string(second.error()).c_str());
    std::abort();
  }
  if (estimate.ok() && estimate->cut_line == 0) {
    auto again = ef::read_tum_trajectory(path);
    if (!again.ok() || again->poses.size() > estimate->poses.size()) {
      std::fprintf(stderr, "a trajectory that read back does not after its rewrite: %s\n",
                   again.ok() ? "more poses" : ef::to_string(again.error()).c_str());
      std::abort();
    }
  }
  return 0;
}
