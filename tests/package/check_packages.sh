#!/usr/bin/env bash
# Checks the Debian packages that scripts/package.sh built (issue 32), as CI's package phase:
#   bash tests/package/check_packages.sh [amd64|arm64|all]     (default: all)
# For each build/packages/edgefusion_<version>_<arch>.deb:
#   1. lintian reports no error (warnings are printed, not fatal);
#   2. its Version is what the packaged `edgefusion version` prints (git describe, cmake/version.cmake);
#   3. every package in its Depends is installed here for its architecture (dpkg-shlibdeps named
#      the libraries the binary links);
#   4. unpacked into an empty folder (dpkg-deb -x), its `edgefusion run` maps the built-in room with
#      the installed model (found from the binary's own location, not this source tree), and
#      `plan` passes the installed /etc configuration; arm64 under qemu-user (QEMU_CPU=cortex-a53);
#   5. its systemd unit passes `systemd-analyze verify` with nothing to report;
#   6. with EF_PACKAGE_INSTALL=1 (CI): amd64 installed with dpkg -i (the service's user and groups,
#      the conffile, the unit verified in place), then purged.
# Needs: scripts/install-deps.sh package. Exits non-zero at the first failure.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
what="${1:-all}"
fail() { echo "check_packages.sh: FAIL: $*" >&2; exit 1; }

check() {
  local arch="$1" deb run=()
  deb="$(ls build/packages/edgefusion_*_"$arch".deb 2>/dev/null | tail -n 1)"
  [ -n "$deb" ] || fail "no build/packages/edgefusion_*_$arch.deb (run scripts/package.sh $arch)"
  echo "=== $deb"
  dpkg-deb --info "$deb" | sed -n '/Package:/,$p'
  if [ "$arch" = arm64 ]; then run=(env QEMU_CPU=cortex-a53 qemu-aarch64 -L /); fi

  echo "--- 1. lintian"
  local lint
  lint="$(lintian --tag-display-limit 0 "$deb" 2>&1 || true)"
  [ -z "$lint" ] || echo "$lint"
  if grep -q '^E: ' <<<"$lint"; then fail "lintian reports errors in $deb"; fi
  echo "lintian: no errors ($(grep -c '^W: ' <<<"$lint" || true) warnings)"

  local root
  root="$(mktemp -d)"
  trap 'rm -rf "$root"' RETURN
  dpkg-deb -x "$deb" "$root"
  local exe="$root/usr/bin/edgefusion"
  [ -x "$exe" ] || fail "$deb has no usr/bin/edgefusion"

  echo "--- 2. version"
  local version printed
  version="$(dpkg-deb --field "$deb" Version)"
  printed="$("${run[@]}" "$exe" version | head -n 1)"
  echo "package $version; program: $printed"
  [ "$printed" = "edgefusion $version" ] || fail "the package's version $version is not the program's ($printed)"

  echo "--- 3. dependencies installed for $arch"
  local depends dep name
  depends="$(dpkg-deb --field "$deb" Depends)"
  [ -n "$depends" ] || fail "$deb declares no dependencies (dpkg-shlibdeps did not run?)"
  grep -q 'libc6' <<<"$depends" || fail "Depends lacks libc6: $depends"
  IFS=',' read -ra deps <<<"$depends"
  for dep in "${deps[@]}"; do
    name="$(sed -E 's/^ *([^ |(]+).*/\1/' <<<"$dep")"
    if dpkg-query -W -f='${Status}' "$name:$arch" 2>/dev/null | grep -q "install ok installed" ||
       dpkg-query -W -f='${Status} ${Architecture}' "$name" 2>/dev/null | grep -Eq "install ok installed (all|$arch)"; then
      echo "  $name ($arch): installed"
    else
      fail "dependency $name of $deb is not installed for $arch"
    fi
  done

  echo "--- 4. the unpacked package maps the built-in room with its installed model"
  local out="$root/run" log="$root/run.log"
  # No EDGEFUSION_MODEL / EDGEFUSION_MODELS_DIR: the binary must find its own models.
  env -u EDGEFUSION_MODEL -u EDGEFUSION_MODELS_DIR "${run[@]}" "$exe" run \
      --source "synthetic:?frames=24&size=160x120" --resolution 160x120 --out "$out" --quiet >"$log" 2>&1 ||
      { cat "$log"; fail "edgefusion run from the unpacked $arch package failed"; }
  cat "$log"
  grep -q "$root/usr/share/edgefusion/models/edgefusion-seg.efm" "$log" ||
      fail "the run did not use the installed model $root/usr/share/edgefusion/models/edgefusion-seg.efm"
  for f in trajectory.txt map.ply stats.json; do [ -s "$out/$f" ] || fail "the run wrote no $f"; done
  grep -q '"state":"finished"' "$out/stats.json" || fail "the run did not finish: $(head -c 200 "$out/stats.json")"
  [ "$(grep -vc '^#' "$out/trajectory.txt")" = 24 ] || fail "trajectory.txt does not hold 24 poses"
  "${run[@]}" "$exe" plan --config "$root/etc/edgefusion/edgefusion.yaml" >"$log" 2>&1 ||
      { cat "$log"; fail "plan refuses the installed /etc/edgefusion/edgefusion.yaml"; }
  tail -n 1 "$log"

  echo "--- 5. systemd-analyze verify"
  local unit="$root/lib/systemd/system/edgefusion.service"
  [ -f "$unit" ] || fail "$deb has no lib/systemd/system/edgefusion.service"
  # The unit as packaged, its commands pointed at the unpacked binary (verify checks that they exist
  # and are executable). verify exits 0 on unknown keys and bad values, which it only prints: any
  # output is a failure.
  local verify
  if [ "$arch" = amd64 ]; then
    sed "s|/usr/bin/edgefusion|$exe|g" "$unit" >"$root/edgefusion.service"
    verify="$(systemd-analyze verify "$root/edgefusion.service" 2>&1)" || fail "systemd-analyze verify: $verify"
    [ -z "$verify" ] || fail "systemd-analyze verify complains about the unit: $verify"
    echo "systemd-analyze verify: passed, nothing to report"
  else
    cmp -s "$unit" firmware_app/systemd/edgefusion.service || fail "the arm64 unit differs from the source's"
    echo "(the arm64 package carries the same unit file, verified with the amd64 package)"
  fi

  # 6. (EF_PACKAGE_INSTALL=1, CI's fresh machine: it changes the system) installed for real with
  # dpkg: the maintainer script makes the service's user with its groups, the configuration is a
  # conffile, the installed unit verifies as it is; then the package is purged (the user and
  # /var/lib/edgefusion stay, as Debian keeps them).
  if [ "$arch" = amd64 ] && [ "${EF_PACKAGE_INSTALL:-0}" = 1 ]; then
    echo "--- 6. dpkg -i, the service's user, systemd-analyze verify in place, dpkg --purge"
    dpkg -i "$deb" || fail "dpkg -i $deb"
    id edgefusion || fail "postinst made no user edgefusion"
    for g in video plugdev gpio; do
      id -nG edgefusion | tr ' ' '\n' | grep -qx "$g" || fail "the user edgefusion is not in the group $g"
    done
    dpkg-query -W -f='${Conffiles}\n' edgefusion | grep -q '/etc/edgefusion/edgefusion.yaml' ||
        fail "/etc/edgefusion/edgefusion.yaml is not a conffile"
    [ "$(/usr/bin/edgefusion version | head -n 1)" = "edgefusion $version" ] || fail "installed /usr/bin/edgefusion version"
    verify="$(systemd-analyze verify /lib/systemd/system/edgefusion.service 2>&1)" || fail "systemd-analyze verify: $verify"
    [ -z "$verify" ] || fail "systemd-analyze verify complains about the installed unit: $verify"
    echo "installed: user $(id edgefusion); unit verified in place"
    dpkg --purge edgefusion >/dev/null || fail "dpkg --purge edgefusion"
    [ ! -e /usr/bin/edgefusion ] || fail "/usr/bin/edgefusion left after purge"
  fi
}

case "$what" in
  amd64|arm64) check "$what" ;;
  all) check amd64; check arm64 ;;
  *) echo "check_packages.sh: unknown architecture '$what' (amd64, arm64 or all)" >&2; exit 2 ;;
esac
echo "check_packages.sh: all checks passed"
