#!/usr/bin/env bash
# Installs the Debian 12 packages EdgeFusion needs. Run as root (or with sudo).
#   install-deps.sh            build and run natively (compiler, CMake, Eigen, OpenCV core/imgproc, PNG/JPEG/zlib,
#                              and for live devices OpenNI2 (with its Dummy test device), libv4l2, libgpiod 1.6)
#   install-deps.sh test       + test tools (GoogleTest, clang/libFuzzer, python3-open3d for the PLY check,
#                              XNNPACK, pthreadpool, cpuinfo for bench_nn_conv's comparison, PyTorch, ONNX
#                              and OpenCV for Python for the tests of models/)
#   install-deps.sh cross      + aarch64 cross compiler, arm64 multiarch libraries, qemu-user
#   install-deps.sh models     base + what models/train.sh needs (PyTorch, ONNX, OpenCV for Python)
# Idempotent: packages already present are skipped quickly by apt.
set -euo pipefail
mode="${1:-base}"
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive

base_pkgs=(build-essential cmake ninja-build pkg-config git
           libeigen3-dev libopencv-core-dev libopencv-imgproc-dev
           libpng-dev libjpeg62-turbo-dev zlib1g-dev
           libopenni2-dev libv4l-dev libgpiod-dev libyaml-cpp-dev)
test_pkgs=(libgtest-dev libgmock-dev libbenchmark-dev clang libclang-rt-14-dev python3 python3-numpy python3-open3d
           libxnnpack-dev libpthreadpool-dev libcpuinfo-dev
           python3-torch python3-onnx python3-opencv)
models_pkgs=(python3 python3-numpy python3-torch python3-onnx python3-opencv)
cross_pkgs=(g++-aarch64-linux-gnu qemu-user
            libpng-dev:arm64 libjpeg62-turbo-dev:arm64 zlib1g-dev:arm64
            libopencv-core-dev:arm64 libopencv-imgproc-dev:arm64 libgtest-dev:arm64
            libopenni2-dev:arm64 libv4l-dev:arm64 libgpiod-dev:arm64
            libyaml-cpp0.7:arm64)

pkgs=("${base_pkgs[@]}")
case "$mode" in
  base) ;;
  test) pkgs+=("${test_pkgs[@]}") ;;
  models) pkgs+=("${models_pkgs[@]}") ;;
  cross) pkgs+=("${test_pkgs[@]}" "${cross_pkgs[@]}")
         if ! dpkg --print-foreign-architectures | grep -qx arm64; then $SUDO dpkg --add-architecture arm64; fi ;;
  *) echo "install-deps.sh: unknown mode '$mode' (expected base, test, cross or models)" >&2; exit 2 ;;
esac

missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then echo "install-deps.sh: all ${#pkgs[@]} packages present"; exit 0; fi
echo "install-deps.sh: installing ${#missing[@]} packages: ${missing[*]}"
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps.sh: done"
