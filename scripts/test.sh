#!/usr/bin/env bash
# THE test command (README): installs the test packages, builds the `release` preset and runs every
# test (ctest: output on failure, 2 at a time). Exits non-zero on any failure.
#   EF_JOBS=<n>  parallel compile jobs (default 2)
#   EF_WERROR=ON any compiler warning in our own code fails the build (.ci/run sets it)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
jobs="${EF_JOBS:-2}"

bash scripts/install-deps.sh test
cmake --preset release -DEF_BUILD_TESTS=ON -DEF_WERROR="${EF_WERROR:-OFF}"
cmake --build --preset release -j "$jobs"
ctest --preset release
