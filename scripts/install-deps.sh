#!/usr/bin/env bash
# Installs the Debian 12 packages EdgeFusion needs. Run as root (or with sudo).
#   install-deps.sh            build and run natively (compiler, CMake, Eigen, OpenCV core/imgproc, PNG/JPEG/zlib,
#                              and for live devices OpenNI2 (with its Dummy test device), libv4l2, libgpiod 1.6;
#                              libsystemd for the service's readiness and watchdog notifications)
#   install-deps.sh test       + test tools (GoogleTest, clang/libFuzzer, python3-open3d for the PLY check,
#                              XNNPACK, pthreadpool, cpuinfo for bench_nn_conv's comparison, PyTorch, ONNX
#                              and OpenCV for Python for the tests of models/, Node.js with the npm readers of
#                              tests/npm: @mcap/core and Foxglove's ROS 2 message readers, for the field logs;
#                              Chromium, which renders report.html headless in tests/scripts/report_html.cmake)
#   install-deps.sh cross      + aarch64 cross compiler, arm64 multiarch libraries, qemu-user
#   install-deps.sh package    cross + what scripts/package.sh and tests/package/check_packages.sh use:
#                              dpkg-dev (dpkg-shlibdeps), lintian, systemd (systemd-analyze verify), fakeroot
#   install-deps.sh models     base + what models/train.sh needs (PyTorch, ONNX, OpenCV for Python)
# Idempotent: packages already present are skipped quickly by apt.
#   EF_DEPS_DOWNLOAD_ONLY=1    fetch the missing packages into apt's cache and install nothing (no dpkg, no npm):
#                              .ci/run downloads the cross and packaging tools while it builds, and installs
#                              them when nothing else is running (an arm64 library can upgrade its amd64 twin)
set -euo pipefail
mode="${1:-base}"
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive

base_pkgs=(build-essential cmake ninja-build pkg-config git
           libeigen3-dev libopencv-core-dev libopencv-imgproc-dev
           libpng-dev libjpeg62-turbo-dev zlib1g-dev
           libopenni2-dev libv4l-dev libgpiod-dev libyaml-cpp-dev libsystemd-dev)
test_pkgs=(libgtest-dev libgmock-dev libbenchmark-dev clang libclang-rt-14-dev python3 python3-numpy python3-open3d
           libxnnpack-dev libpthreadpool-dev libcpuinfo-dev
           python3-torch python3-onnx python3-opencv nodejs chromium)
models_pkgs=(python3 python3-numpy python3-torch python3-onnx python3-opencv)
cross_pkgs=(g++-aarch64-linux-gnu qemu-user
            libpng-dev:arm64 libjpeg62-turbo-dev:arm64 zlib1g-dev:arm64
            libopencv-core-dev:arm64 libopencv-imgproc-dev:arm64 libgtest-dev:arm64
            libopenni2-dev:arm64 libv4l-dev:arm64 libgpiod-dev:arm64
            libyaml-cpp0.7:arm64 libsystemd-dev:arm64)
package_pkgs=(dpkg-dev lintian systemd fakeroot file adduser)

pkgs=("${base_pkgs[@]}")
case "$mode" in
  base) ;;
  test) pkgs+=("${test_pkgs[@]}") ;;
  models) pkgs+=("${models_pkgs[@]}") ;;
  cross|package)
         pkgs+=("${test_pkgs[@]}" "${cross_pkgs[@]}")
         if [ "$mode" = package ]; then pkgs+=("${package_pkgs[@]}"); fi
         if ! dpkg --print-foreign-architectures | grep -qx arm64; then $SUDO dpkg --add-architecture arm64; fi ;;
  *) echo "install-deps.sh: unknown mode '$mode' (expected base, test, cross, package or models)" >&2; exit 2 ;;
esac

# npm comes with some nodejs builds (NodeSource's) and is Debian's own package otherwise.
if [ "$mode" = test ] || [ "$mode" = cross ] || [ "$mode" = package ]; then
  if ! command -v npm >/dev/null 2>&1; then pkgs+=(npm); fi
fi

# The test-side npm readers (tests/npm/package-lock.json), once apt's part is done.
npm_readers() {
  if [ "$mode" != test ] && [ "$mode" != cross ] && [ "$mode" != package ]; then return 0; fi
  local dir
  dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/tests/npm"
  if [ -d "$dir/node_modules/@mcap/core" ]; then return 0; fi
  echo "install-deps.sh: npm ci in tests/npm (@mcap/core, @foxglove/rosmsg, @foxglove/rosmsg2-serialization)"
  if ! (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error); then
    echo "install-deps.sh: warning: npm ci failed (no registry?): the tests that read field logs with @mcap/core will skip" >&2
  fi
}

missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then echo "install-deps.sh: all ${#pkgs[@]} packages present"; npm_readers; exit 0; fi
echo "install-deps.sh: installing ${#missing[@]} packages: ${missing[*]}"
$SUDO apt-get update -qq
if [ "${EF_DEPS_DOWNLOAD_ONLY:-0}" = 1 ]; then
  $SUDO apt-get install -y -qq --no-install-recommends --download-only "${missing[@]}" >/dev/null
  echo "install-deps.sh: downloaded (EF_DEPS_DOWNLOAD_ONLY=1: nothing installed)"
  exit 0
fi
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
npm_readers
echo "install-deps.sh: done"
