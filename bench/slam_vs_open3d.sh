#!/usr/bin/env bash
# EdgeFusion's tracking + fusion against Open3D's frame-to-frame RGB-D odometry, side by side: the same
# 7-Scenes frames at 320x240, both on one thread (OMP_NUM_THREADS=1), ms/frame and ATE for each.
#
# Usage:
#   bash bench/slam_vs_open3d.sh [--frames N] [--data DIR] [--edgefusion BIN] [--out DIR]
#
#   --frames N        frames from frame 0 (default 1000, the whole redkitchen sequence, about 3 minutes
#                     on 2 cores; 100 for a quick run: Open3D takes 80-130 ms/frame plus ~25 ms loading)
#   --data DIR        7-Scenes sequence folder (default ../shared/data/7scenes-redkitchen, relative to
#                     the repository root)
#   --edgefusion BIN  the edgefusion binary to use (also: environment variable EDGEFUSION); without one
#                     the script builds the `edgefusion` target alone into $EF_BUILD_DIR (default
#                     build/release, preset "release") with $JOBS parallel jobs (default 2)
#   --out DIR         keep every output in DIR (default: a temporary folder, removed at the end)
#
# Environment: PYTHON (default /usr/bin/python3, which sees Debian's python3-open3d), EF_SLAM_STAGES
# (default "preprocess predict track fuse": the stats.json stages summed as EdgeFusion's
# tracking + fusion time).
#
# What it runs, one after the other (never together, so they do not share the cores):
#   1. OMP_NUM_THREADS=1 edgefusion run --threads 1 --source 7scenes:DIR --resolution 320x240 --frames N --out OUT/ours
#      EdgeFusion's ms/frame = the sum of the per-stage medians (and means) in OUT/ours/stats.json of
#      those EF_SLAM_STAGES it finds; the whole run's wall ms/frame (decoding included) beside it.
#   2. OMP_NUM_THREADS=1 $PYTHON bench/open3d_odometry.py --data DIR --frames N --resolution 320x240
#      Open3D 0.16 compute_rgbd_odometry, hybrid term, default OdometryOption, each frame against the
#      previous one; the frames are shrunk the way EdgeFusion shrinks them (see that file's header).
#      Its ms/frame is the median (and mean) of the odometry call alone.
#   3. edgefusion convert --source 7scenes:DIR --to tum:OUT/reference --frames N --resolution 80x60:
#      the reference trajectory (OUT/reference/groundtruth.txt, the source's poses at index / 30 s
#      like both trajectories; the small images written beside it are not used);
#   4. edgefusion eval ate for both trajectories (RMSE after rigid alignment).
# Then a table: system, ms/frame (median, mean), wall ms/frame, ATE RMSE in cm, failures; the ratio of
# Open3D's median time to ours, and the issue's goal (ours at most one fifth of Open3D's time, ATE below
# InfiniTAM's 2.80 cm).
#
# Timings are only meaningful on otherwise idle cores: the CPU model and the load average are printed,
# and Open3D's process CPU time is shown beside its wall time (a large gap means the cores were shared).
#
# Exit status: 0 after a complete comparison (whether or not the goal is met); 2 with a message when
# the data folder or Open3D is missing (skip) or an option is wrong; 1 when a step fails.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
frames=1000
data="$repo/../shared/data/7scenes-redkitchen"
edgefusion="${EDGEFUSION:-}"
out=""
python="${PYTHON:-/usr/bin/python3}"
build_dir="${EF_BUILD_DIR:-$repo/build/release}"
jobs="${JOBS:-2}"
slam_stages="${EF_SLAM_STAGES:-preprocess predict track fuse}"
resolution=320x240
goal_ratio=5
goal_ate_cm=2.80

usage() { sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d' | sed 's/^# \{0,1\}//'; }
die() { echo "slam_vs_open3d: $2" >&2; exit "$1"; }

while [[ $# -gt 0 ]]; do
  case "$1" in
    --frames) [[ $# -ge 2 ]] || die 2 "--frames needs a value"; frames="$2"; shift 2 ;;
    --data) [[ $# -ge 2 ]] || die 2 "--data needs a value"; data="$2"; shift 2 ;;
    --edgefusion) [[ $# -ge 2 ]] || die 2 "--edgefusion needs a value"; edgefusion="$2"; shift 2 ;;
    --out) [[ $# -ge 2 ]] || die 2 "--out needs a value"; out="$2"; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    *) die 2 "unknown argument '$1' (see --help)" ;;
  esac
done
[[ "$frames" =~ ^[1-9][0-9]*$ ]] || die 2 "--frames: '$frames' is not a positive integer"
[[ "$frames" -ge 2 ]] || die 2 "--frames: odometry needs at least 2 frames"

# Skips: no data, no Open3D.
if [[ ! -d "$data" ]]; then
  echo "slam_vs_open3d: SKIPPED: data folder '$data' not found (the 7-Scenes redkitchen frames live in" \
       "../shared/data/, outside the repository; pass --data DIR)" >&2
  exit 2
fi
data="$(cd "$data" && pwd)"
[[ -f "$data/frame-000000.depth.png" ]] || die 2 "'$data' holds no frame-000000.depth.png (not a 7-Scenes sequence folder)"
if ! OMP_NUM_THREADS=1 "$python" -c 'import numpy, open3d' >/dev/null 2>&1; then
  echo "slam_vs_open3d: SKIPPED: $python cannot import open3d and numpy (Debian 12: apt-get install" \
       "python3-open3d; or set PYTHON to an interpreter that has them)" >&2
  exit 2
fi

# The edgefusion binary: given, or built (the one target only).
if [[ -z "$edgefusion" ]]; then
  echo "== building edgefusion in $build_dir (-j$jobs)" >&2
  cmake --preset release -S "$repo" -B "$build_dir" >/dev/null || die 1 "cmake configure failed"
  cmake --build "$build_dir" -j"$jobs" --target edgefusion >&2 || die 1 "build failed"
  edgefusion="$build_dir/firmware_app/edgefusion"
  [[ -x "$edgefusion" ]] || die 1 "no $edgefusion after the build"
fi
[[ -x "$edgefusion" ]] || die 2 "edgefusion binary '$edgefusion' not found or not executable"

keep_note=""
if [[ -z "$out" ]]; then
  out="$(mktemp -d "${TMPDIR:-/tmp}/slam_vs_open3d.XXXXXX")"
  trap 'rm -rf "$out"' EXIT
  keep_note=" (temporary, removed on exit; --out DIR keeps them)"
else
  mkdir -p "$out"
  out="$(cd "$out" && pwd)"
fi

# Reads one value out of a JSON file: json_get FILE PYTHON-EXPRESSION-ON-d
json_get() { "$python" -c 'import json, sys; d = json.load(open(sys.argv[1])); print(eval(sys.argv[2]))' "$1" "$2"; }
# Reads "key value" lines of `edgefusion eval ate`: ate_value FILE KEY
ate_value() { awk -v k="$2" '$1 == k { print $2 }' "$1"; }

echo "== machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores online," \
     "load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "== edgefusion: $edgefusion ($("$edgefusion" version 2>/dev/null | head -n 1))"
echo "== data: $data, $frames frames at $resolution, OMP_NUM_THREADS=1"

echo "== 1/4 EdgeFusion: edgefusion run" >&2
OMP_NUM_THREADS=1 "$edgefusion" run --threads 1 --source "7scenes:$data" --resolution "$resolution" --frames "$frames" \
  --out "$out/ours" --overwrite --quiet > "$out/ours.log" 2>&1 || { cat "$out/ours.log" >&2; die 1 "edgefusion run failed"; }
[[ -f "$out/ours/stats.json" ]] || die 1 "edgefusion run wrote no $out/ours/stats.json"
[[ -f "$out/ours/trajectory.txt" ]] || die 1 "edgefusion run wrote no $out/ours/trajectory.txt"

echo "== 2/4 Open3D: bench/open3d_odometry.py" >&2
OMP_NUM_THREADS=1 "$python" "$repo/bench/open3d_odometry.py" --data "$data" --frames "$frames" \
  --resolution "$resolution" --out "$out/open3d/trajectory.txt" --stats "$out/open3d/stats.json" --quiet \
  > "$out/open3d.log" 2>&1 || { cat "$out/open3d.log" >&2; die 1 "open3d_odometry.py failed"; }

echo "== 3/4 reference trajectory: edgefusion convert" >&2
# The poses do not depend on the image size: 80x60 only makes the images written beside them cheap.
"$edgefusion" convert --source "7scenes:$data" --to "tum:$out/reference" --frames "$frames" \
  --resolution 80x60 --quiet > "$out/reference.log" 2>&1 || { cat "$out/reference.log" >&2; die 1 "edgefusion convert failed"; }
reference="$out/reference/groundtruth.txt"
[[ -f "$reference" ]] || die 1 "edgefusion convert wrote no $reference (the sequence has no poses?)"

echo "== 4/4 ATE: edgefusion eval ate" >&2
for who in ours open3d; do
  "$edgefusion" eval ate "$reference" "$out/$who/trajectory.txt" > "$out/$who.ate" 2>&1 \
    || { cat "$out/$who.ate" >&2; die 1 "edgefusion eval ate failed for $who"; }
done

# EdgeFusion's figures from stats.json.
ours_summary="$("$python" - "$out/ours/stats.json" "$slam_stages" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
stages = d.get("stages", {})
wanted = sys.argv[2].split()
found = [s for s in wanted if s in stages]
median = sum(stages[s]["median_ms"] for s in found)
mean = sum(stages[s]["mean_ms"] for s in found)
wall = 1e3 * d["seconds"] / d["frames"] if d.get("frames") else float("nan")
print("%d %.3f %.3f %.3f %s" % (d.get("frames", 0), median, mean, wall, "+".join(found) if found else "-"))
EOF
)"
read -r ours_frames ours_median ours_mean ours_wall ours_stages <<< "$ours_summary"
ours_ate="$(ate_value "$out/ours.ate" ate_rmse_m)"
ours_pairs="$(ate_value "$out/ours.ate" pairs)"

o3d_stats="$out/open3d/stats.json"
o3d_median="$(json_get "$o3d_stats" '"%.3f" % d["odometry_median_ms"]')"
o3d_mean="$(json_get "$o3d_stats" '"%.3f" % d["odometry_mean_ms"]')"
o3d_cpu="$(json_get "$o3d_stats" '"%.3f" % d["odometry_cpu_median_ms"]')"
o3d_fail="$(json_get "$o3d_stats" 'd["failures"]')"
o3d_version="$(json_get "$o3d_stats" 'd["open3d_version"]')"
o3d_ate="$(ate_value "$out/open3d.ate" ate_rmse_m)"
o3d_pairs="$(ate_value "$out/open3d.ate" pairs)"

echo
echo "stages in EdgeFusion's stats.json (median ms):" \
     "$(json_get "$out/ours/stats.json" '"  ".join("%s %.2f" % (k, v["median_ms"]) for k, v in d["stages"].items())')"
if [[ "$ours_stages" == "-" ]]; then
  echo "NOTE: none of the stages '$slam_stages' is in EdgeFusion's stats.json: no tracking or fusion ran, and its" \
       "trajectory is the source's reference poses (ATE ~0 by construction)."
fi
[[ "$ours_frames" == "$frames" ]] || echo "NOTE: EdgeFusion processed $ours_frames frames, not $frames"
[[ "$ours_pairs" == "$frames" && "$o3d_pairs" == "$frames" ]] \
  || echo "NOTE: ATE pairs: EdgeFusion $ours_pairs, Open3D $o3d_pairs, expected $frames"

"$python" - "$ours_stages" "$ours_median" "$ours_mean" "$ours_wall" "$ours_ate" \
  "$o3d_version" "$o3d_median" "$o3d_mean" "$o3d_cpu" "$o3d_ate" "$o3d_fail" "$frames" "$goal_ratio" "$goal_ate_cm" <<'EOF'
import math, sys
(stages, om, oa, ow, oate, ver, pm, pa, pc, pate, pfail, frames, goal_ratio, goal_ate) = sys.argv[1:]
om, oa, ow, oate, pm, pa, pc, pate = (float(v) for v in (om, oa, ow, oate, pm, pa, pc, pate))
goal_ratio, goal_ate = float(goal_ratio), float(goal_ate)
have = stages != "-"
def ms(v):
    return "%.2f" % v if have or v != 0 else "n/a"
print()
print("%-44s %10s %10s %10s %12s %9s" % ("system (%s frames, 320x240, 1 thread)" % frames,
                                        "ms/frame", "mean ms", "wall ms", "ATE RMSE cm", "failures"))
print("%-44s %10s %10s %10.2f %12.2f %9s" % ("EdgeFusion tracking + fusion",
                                            ms(om), ms(oa), ow, 100 * oate, "-"))
print("%-44s %10.2f %10.2f %10s %12.2f %9s" % ("Open3D %s RGB-D odometry, hybrid, f2f" % ver,
                                              pm, pa, "-", 100 * pate, pfail))
print("ms/frame: median per frame; EdgeFusion: the sum of the medians of its stages %s, wall = the"
      " whole run per frame (decoding included); Open3D: the odometry call alone (process CPU time"
      " %.2f ms median)" % (stages if have else "(none found)", pc))
if have and om > 0:
    ratio = pm / om
    print("Open3D / EdgeFusion time: %.2fx" % ratio)
    time_ok, ate_ok = ratio >= goal_ratio, 100 * oate < goal_ate
    print("goal (EdgeFusion <= 1/%g of Open3D's time: %s; ATE < %.2f cm: %s): %s"
          % (goal_ratio, "yes" if time_ok else "no", goal_ate, "yes" if ate_ok else "no",
             "MET" if time_ok and ate_ok else "NOT MET"))
else:
    print("Open3D / EdgeFusion time: n/a (no tracking or fusion stages timed)")
EOF
echo
echo "outputs: $out$keep_note"
