#!/usr/bin/env bash
# Builds the Debian packages of `edgefusion` (issue 32) with CPack's DEB generator:
#   bash scripts/package.sh [amd64|arm64|all]     (default: all)
# into build/packages/edgefusion_<version>_<arch>.deb. amd64 from the `release` preset, arm64 from the
# `aarch64` cross preset (both configured with the install prefix /usr and built here if needed).
# Run-time dependencies come from the linked libraries through dpkg-shlibdeps; for arm64 it reads the
# arm64 multiarch libraries (scripts/install-deps.sh cross), told the target by DEB_HOST_ARCH.
# Needs: scripts/install-deps.sh package (dpkg-dev, fakeroot; the cross toolchain for arm64).
#   EF_JOBS=<n>  parallel compile jobs (default 2)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
jobs="${EF_JOBS:-2}"
what="${1:-all}"
case "$what" in amd64|arm64|all) ;; *) echo "package.sh: unknown architecture '$what' (amd64, arm64 or all)" >&2; exit 2 ;; esac
mkdir -p build/packages

# package <preset> <deb architecture>
package() {
  local preset="$1" arch="$2" dir="build/$1"
  echo "--- package.sh: $arch from the $preset preset ($dir)"
  # Only the install prefix is added to the preset's configuration: nothing recompiles for it.
  cmake --preset "$preset" -DCMAKE_INSTALL_PREFIX=/usr >/dev/null
  cmake --build "$dir" -j "$jobs" --target edgefusion
  rm -f "$dir"/edgefusion_*.deb
  (cd "$dir" && DEB_HOST_ARCH="$arch" cpack -G DEB -C Release >/dev/null)
  local deb
  deb="$(ls "$dir"/edgefusion_*_"$arch".deb)"
  rm -f build/packages/edgefusion_*_"$arch".deb
  cp "$deb" build/packages/
  echo "package.sh: build/packages/$(basename "$deb")"
  dpkg-deb --field "$deb" Package Version Architecture Depends
}

if [ "$what" = amd64 ] || [ "$what" = all ]; then package release amd64; fi
if [ "$what" = arm64 ] || [ "$what" = all ]; then package aarch64 arm64; fi
