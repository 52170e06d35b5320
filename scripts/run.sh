#!/usr/bin/env bash
# The main job on a fresh Debian 12 machine: install what is needed, build the release preset, and run
# `edgefusion run` on the built-in default source (the synthetic living room). Extra arguments are
# passed to `edgefusion run` (for example: --source 7scenes:../shared/data/7scenes-redkitchen).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh base
# Its own build folder: the program only, so the test packages are not needed.
cmake -S . -B build/app -G Ninja -DCMAKE_BUILD_TYPE=Release -DEF_BUILD_TESTS=OFF -DEF_BUILD_BENCH=OFF >/dev/null
cmake --build build/app --target edgefusion
out="${EF_OUT:-out/run}"
if [ $# -eq 0 ]; then set -- --source synthetic:; fi
# The demo's own folder: each run replaces the one before (--overwrite). Runs of your own into
# another folder are never overwritten without it.
exec build/app/firmware_app/edgefusion run "$@" --out "$out" --overwrite
