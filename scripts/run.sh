#!/usr/bin/env bash
# The main job on a fresh Debian 12 machine: install what is needed, build the release preset, and run
# `edgefusion run` on the built-in default source (the synthetic living room). Extra arguments are
# passed to `edgefusion run` (for example: --source 7scenes:../shared/data/7scenes-redkitchen).
#
# Where it writes: out/run (or $EF_OUT), replaced by each run (--overwrite). With your own --out DIR
# the arguments go to `edgefusion run` as they are: your folder, never overwritten unless you also
# pass --overwrite.
#
# EF_RUN_DRY=1 prints the `edgefusion run` command instead of installing, building and running it
# (tests/scripts/test_run_sh.sh checks the arguments that way).
set -euo pipefail
cd "$(dirname "$0")/.."
# The built-in room rendered at the working resolution (320x240): the demo then shows the mapper's
# own rate, not the renderer's (at its default 640x480 the CPU renderer takes about 4x longer per
# frame than mapping it).
if [ $# -eq 0 ]; then set -- --source "synthetic:?size=320x240"; fi
own_out=0
for a in "$@"; do
  case "$a" in --out|--out=*) own_out=1 ;; esac
done
if [ "$own_out" = 0 ]; then set -- "$@" --out "${EF_OUT:-out/run}" --overwrite; fi
if [ "${EF_RUN_DRY:-0}" = 1 ]; then
  echo "build/app/firmware_app/edgefusion run $*"
  exit 0
fi
bash scripts/install-deps.sh base
# Its own build folder: the program only, so the test packages are not needed.
cmake -S . -B build/app -G Ninja -DCMAKE_BUILD_TYPE=Release -DEF_BUILD_TESTS=OFF -DEF_BUILD_BENCH=OFF >/dev/null
cmake --build build/app --target edgefusion
exec build/app/firmware_app/edgefusion run "$@"
