#!/usr/bin/env bash
# The main job on a fresh Debian 12 machine: install what is needed, build the release preset, and run
# `edgefusion run` on the built-in default source (the synthetic living room). Extra arguments are
# passed to `edgefusion run` (for example: --source 7scenes:../shared/data/7scenes-redkitchen).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh base
cmake --preset release -DEF_BUILD_TESTS=OFF >/dev/null
cmake --build --preset release --target edgefusion
out="${EF_OUT:-out/run}"
if [ $# -eq 0 ]; then set -- --source synthetic:; fi
exec build/release/firmware_app/edgefusion run "$@" --out "$out"
