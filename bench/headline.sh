#!/usr/bin/env bash
# Every figure the README claims, measured side by side in one run on this machine, into
# docs/headline.md (and the README's copy of its table). Rerun it before you stop whenever a change
# can move one of them; never copy a figure into the README by hand.
#
#   bash bench/headline.sh [--frames N] [--reps R] [--no-readme]
#
#   --frames N    7-Scenes frames for every run (default 1000: the whole kitchen sequence)
#   --reps R      repetitions of the end-to-end runs (default 3; medians are quoted)
#   --no-readme   write docs/headline.md only
#
# What it does (about 20 minutes on 2 cores from a clean clone, the build included):
#   1. installs the test packages (scripts/install-deps.sh test: Open3D, XNNPACK) and builds the
#      release preset's `edgefusion`, `bench_nn_conv`, `bench_nn_model`, `bench_slam_stages` and
#      `bench_crf` (tests off) in build/headline
#   2. bench/headline.py: the SLAM against Open3D's odometry (bench/slam_vs_open3d.sh, one thread
#      each, ATE of both; bench/reference_consistency.py --far 300: the drift of ours and of the
#      reference poses between frames far apart, against direct registration), the CNN's
#      convolutions against XNNPACK and the whole forward pass (bench_nn_conv / bench_nn_model on
#      the shipped model), the end-to-end rate and peak memory of
#      `edgefusion run` with one and two threads (bench/pipeline_hz.py's runs), the dense CRF over the
#      map of one of those runs (bench_crf --checkpoint) and the CRF's plan at the default pool, and
#      the SLAM's cost as a 10,000-frame synthetic map grows (bench/slam_growth.sh); the machine, the
#      load and the commit are printed with them.
# Needs ../shared/data/7scenes-redkitchen (real Kinect frames); without it, it stops and says so.
# Timings mean something only on otherwise idle cores: the load average is recorded.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
start=$SECONDS
jobs="${JOBS:-2}"
build="${EF_HEADLINE_BUILD:-build/headline}"

if [ ! -d ../shared/data/7scenes-redkitchen ] && [ -z "${EF_SHARED_DATA:-}" ]; then
  echo "headline: ../shared/data/7scenes-redkitchen not found: the headline figures are measured on it" >&2
  exit 2
fi
bash scripts/install-deps.sh test >&2
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DEF_BUILD_TESTS=OFF -DEF_BUILD_BENCH=ON >/dev/null
cmake --build "$build" -j "$jobs" --target edgefusion bench_nn_conv bench_nn_model bench_slam_stages bench_crf >&2
echo "headline: built in $((SECONDS - start)) s" >&2
exec /usr/bin/python3 bench/headline.py --build "$build" --setup-seconds "$((SECONDS - start))" "$@"
