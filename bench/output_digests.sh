#!/usr/bin/env bash
# Digests of what `edgefusion run` writes, for proving that a change which should not move any output
# (a refactoring) did not: run it with the program before and after the change and `diff` the two
# listings. Timings (stats.json) differ run to run and are left out; everything else a run writes is
# hashed: trajectory.txt, map.ply and every label image.
#
#   bash bench/output_digests.sh [EDGEFUSION] > digests.txt      (default build/release/firmware_app/edgefusion)
#   EF_DIGEST_QUICK=1 ...   the synthetic runs only (about a minute; the full set about 5 minutes)
#   EF_DIGEST_FLAGS="--deterministic" ...   flags added to every run (a program whose CNN runs beside
#                           the mapper needs --deterministic for labels that do not depend on timing)
#
# The runs (each in its own folder under $EF_DIGEST_DIR, default a temporary one):
#   7scenes      the real 7-Scenes kitchen, 1000 frames, defaults, label images as they arrive and
#                from the finished map (skipped with a message when ../shared is absent)
#   synth-*      built-in rooms: the defaults with a final CRF, every thread layout, geometry only,
#                and a configuration file that sets every mapping, label and CRF key away from its
#                default, so that each key's path from the file to the code is covered.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bin="$(realpath "${1:-build/release/firmware_app/edgefusion}")"
data="${EF_SHARED_DATA:-$PWD/../shared/data}"
work="${EF_DIGEST_DIR:-$(mktemp -d)}"
mkdir -p "$work"

cat >"$work/every-key.yaml" <<'EOF'
source: "synthetic:random?seed=21&frames=60&size=320x240"
resolution: 160x120
mapping:
  surfel_capacity: 200000
  icp_weight: 5
  rgb_weight: 0.5
  rgb_boost_condition: 0
  rgb_boost_max: 4
  constant_velocity_guess: false
  depth_cutoff_m: 4
  index_map_scale: 2
  associate_at_tracked_pose: false
labels:
  every: 5
  out_every: 7
  visibility: false
crf:
  every: 25
  final: true
  iterations: 4
pipeline:
  threads: 3
  prepared_slots: 5
memory:
  budget_mb: 1000
EOF

# run NAME ARGS...: one run into $work/NAME, then the digests of its outputs, one line per file.
run() {
  local name="$1"
  shift
  rm -rf "${work:?}/$name"
  # shellcheck disable=SC2086 # EF_DIGEST_FLAGS is a list of flags
  "$bin" run --quiet --out "$work/$name" "$@" ${EF_DIGEST_FLAGS:-} >"$work/$name.log" 2>&1 || {
    echo "output_digests: run $name failed (exit $?):" >&2
    cat "$work/$name.log" >&2
    exit 1
  }
  (cd "$work" && find "$name" -type f ! -name stats.json | sort | xargs sha256sum)
}

if [ -z "${EF_DIGEST_QUICK:-}" ]; then
  if [ -d "$data/7scenes-redkitchen" ]; then
    run 7scenes --source "7scenes:$data/7scenes-redkitchen" --labels-out "$work/7scenes/labels" \
        --labels-out-every 50 --labels-final-out "$work/7scenes/final" --memory-budget-mb 1000
  else
    echo "# 7scenes: skipped ($data/7scenes-redkitchen not found)"
  fi
fi
run synth-default --source "synthetic:?size=320x240" --labels-out "$work/synth-default/labels" --crf-final \
    --surfel-capacity 400000 --memory-budget-mb 1000
for t in 1 3; do
  run "synth-threads$t" --source "synthetic:random?seed=7&frames=80&size=320x240" --threads "$t" \
      --labels-out "$work/synth-threads$t/labels"
done
run synth-geometry --source "synthetic:kitchen?frames=80&size=320x240&trajectory=robot" --no-labels
run synth-every-key --config "$work/every-key.yaml" --labels-out "$work/synth-every-key/labels"
