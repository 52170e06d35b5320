#!/usr/bin/env bash
# The distillation sweep of issue 28's item 8 on a GPU machine: several students trained at once
# from one data pack (`python3 -m edgefusion_models.distill ... --pack PACK`, made where the
# edgefusion binary is), each with its own settings, all on one GPU. The machine needs PyTorch and
# OpenCV's Python module; it needs neither the binary nor ../shared.
#   bash models/distill_sweep.sh PACK OUT_DIR [TIME_BUDGET_S]
# Writes OUT_DIR/<name>.pt and <name>_history.json per student and one calibration set
# (calibration.npz) for their int8 export, which runs back where the binary is:
#   python3 -m edgefusion_models.export --checkpoint OUT/<name>.pt --calibration-npz OUT/calibration.npz ...
#   python3 -m edgefusion_models.distill --evaluate ... --student <name>.efm
# Each student stops early if its first epoch shows it would outrun TIME_BUDGET_S (default 300).
set -euo pipefail
pack="$(realpath "$1")"; out="$(realpath -m "$2")"; budget="${3:-300}"
cd "$(dirname "$0")"
mkdir -p "$out"
py="${PYTHON:-python3}"
device=$("$py" -c 'import torch; print("cuda" if torch.cuda.is_available() else "cpu")')
echo "distill_sweep: device $device, budget ${budget} s a student"
#       name             settings
runs=("shipped12        --init checkpoints/edgesegnet.pt --epochs 12"
      "shipped150       --init checkpoints/edgesegnet.pt --epochs 150"
      "shipped150zoom   --init checkpoints/edgesegnet.pt --epochs 150 --max-zoom 1.5"
      "w2x150           --init '' --width 2 --epochs 150"
      "w2x150zoom       --init '' --width 2 --epochs 150 --max-zoom 1.5"
      "w3x150zoom       --init '' --width 3 --epochs 150 --max-zoom 1.5")
pids=()
for r in "${runs[@]}"; do
  name=${r%% *}; settings=${r#* }
  eval "\"$py\" -m edgefusion_models.distill --from-pack '$pack' --holdout-from "${EF_HOLDOUT_FROM:-700}" --device $device \
    --threads 2 --time-budget-s $budget --out '$out/$name.pt' $settings" > "$out/$name.log" 2>&1 &
  pids+=($!)
done
fail=0
for p in "${pids[@]}"; do wait "$p" || fail=1; done
for r in "${runs[@]}"; do name=${r%% *}; echo "== $name"; tail -3 "$out/$name.log"; done
mv "$out/shipped12_calibration.npz" "$out/calibration.npz" 2>/dev/null || true
rm -f "$out"/*_calibration.npz
exit $fail
