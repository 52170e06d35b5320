#!/usr/bin/env bash
# Does the per-frame SLAM cost grow with the map? Issue 31's "flat with the map": over a long run the
# median of the four SLAM stages over the last 1,000 frames must be within 20% of frames 1,000-1,999,
# while the map keeps growing.
#
#   bash bench/slam_growth.sh [--source URI] [--frames N] [--window N] [--bench BIN]
#
#   --source URI   default synthetic:random?seed=5001&trajectory=robot&frames=10000&size=320x240 (a
#                  robot's 10,000-frame path through a random room of the held-out seeds, with the
#                  synthetic depth noise; about 3.5 minutes here)
#   --frames N     frames to process (default: all the source has)
#   --window N     frames per row of the table (default 1000)
#   --bench BIN    bench_slam_stages to use (also: $BENCH_SLAM_STAGES); without one the script builds
#                  that target into $EF_BUILD_DIR (default build/release) with $JOBS jobs (default 2)
#
# Prints bench_slam_stages --window's table (per window: the surfels at its end, the medians of
# preprocess, track, fuse, predict and their sum, and the share of the pool's blocks predict visited;
# slam/surfel_pool.h, block bounds), then the ratio of the last window's median sum to the second's
# and the goal. One thread; the CPU and load average are printed. Exit 0 after a complete run (goal
# met or not), 2 when the bench cannot be built or run.
set -euo pipefail
cd "$(dirname "$0")/.."
source_uri="synthetic:random?seed=5001&trajectory=robot&frames=10000&size=320x240"
frames=""
window=1000
bench="${BENCH_SLAM_STAGES:-}"
while [ $# -gt 0 ]; do
  case "$1" in
    --source) source_uri="$2"; shift 2 ;;
    --frames) frames="$2"; shift 2 ;;
    --window) window="$2"; shift 2 ;;
    --bench) bench="$2"; shift 2 ;;
    -h|--help) sed -n '2,21p' "$0"; exit 0 ;;
    *) echo "slam_growth.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
if [ -z "$bench" ]; then
  build="${EF_BUILD_DIR:-build/release}"
  [ -f "$build/build.ninja" ] || cmake --preset release >/dev/null || { echo "slam_growth.sh: cannot configure $build" >&2; exit 2; }
  ninja -C "$build" -j "${JOBS:-2}" bench/bench_slam_stages >/dev/null || { echo "slam_growth.sh: cannot build bench_slam_stages" >&2; exit 2; }
  bench="$build/bench/bench_slam_stages"
fi
echo "slam_growth.sh: $(date -u '+%Y-%m-%d %H:%M') UTC, commit $(git rev-parse --short HEAD 2>/dev/null || echo unknown), load average $(cut -d' ' -f1-3 /proc/loadavg)"
args=(--source "$source_uri" --window "$window")
[ -n "$frames" ] && args+=(--frames "$frames")
out=$(mktemp)
trap 'rm -f "$out"' EXIT
"$bench" "${args[@]}" 2>/dev/null | tee "$out" || { echo "slam_growth.sh: bench_slam_stages failed" >&2; exit 2; }
# Rows of the window table: "  a-b  surfels  pre track fuse predict sum  share%".
awk -v w="$window" '
  $1 ~ /^[0-9]+-[0-9]+$/ && NF == 8 { n++; sum[n] = $7; surfels[n] = $2 }
  END {
    if (n < 3) { print "slam_growth.sh: fewer than 3 windows: nothing to compare"; exit }
    ratio = sum[n] / sum[2]
    printf "last window / second window (median sum): %.2f / %.2f ms = %.2f (goal: at most 1.20); surfels %d -> %d\n",
           sum[n], sum[2], ratio, surfels[2], surfels[n]
  }' "$out"
