#!/usr/bin/env bash
# The real-camera network's input size, chosen by measurement (issue 28): DeepLabv3-MobileNetV2 is
# fully convolutional, so the TFLite file (fixed at 513x513) can be imported at any size whose sides
# are 8k+1. For each size: the import (models/import_deeplab.sh's recipe: 40 real 7-Scenes calibration
# frames, none of them one the agreement is measured on), its multiply-adds, the forward pass on one thread
# (`edgefusion segment --threads 1`, median over the frames), and the int8 model's argmax agreement
# with the float reference of the file at the same size (edgefusion_models.agreement) on every K-th
# of the 1000 real 7-Scenes frames.
#
#   bash bench/deeplab_sizes.sh [EDGEFUSION] [EVERY]     (defaults build/release/firmware_app/edgefusion, 20)
#   EF_SIZES="161x121 257x193" ...   the sizes (default 129x97 161x121 193x145 257x193 321x241)
#   EF_SIZES_WORK=DIR ...   keep the imported models in DIR (default: a temporary folder)
# Prints a Markdown table. About 5 minutes per size on 2 cores.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bin="$(realpath "${1:-build/release/firmware_app/edgefusion}")"
every="${2:-20}"
shared="$(realpath "${EF_SHARED:-../shared}")"
src="$shared/models/deeplabv3-mnv2-ade20k"
kitchen="$shared/data/7scenes-redkitchen"
[ -d "$kitchen" ] || { echo "deeplab_sizes: $kitchen not found" >&2; exit 1; }
if [ -n "${EF_SIZES_WORK:-}" ]; then  # keep the imported models there
  work="$EF_SIZES_WORK"
  mkdir -p "$work"
else
  work="$(mktemp -d)"
  trap 'rm -rf "$work"' EXIT
fi
echo "| input | output | multiply-adds | forward, 1 thread (median) | agreement with float (every ${every}th frame) | worst frame |"
echo "|---|---|---|---|---|---|"
for size in ${EF_SIZES:-129x97 161x121 193x145 257x193 321x241}; do
  model="$work/deeplab-$size.efm"
  (cd models && PYTHONPATH=. /usr/bin/python3 -m edgefusion_models.import_tflite --quiet \
    --tflite "$src/deeplabv3-mnv2-ade20k.tflite" --input "$size" --class-map "$src/ade20k_to_nyu13.json" \
    --labels "$src/ade20k-labels.txt" --frames 40 --edgefusion "$bin" --out "$model" \
    --calibration "7scenes:$kitchen")
  macs=$("$bin" model info "$model" | awk '$1 == "mmacs" {printf "%.2f G", $2 / 1000}')
  out=$("$bin" model info "$model" | awk '$1 == "output" {print $2}')
  fwd=$("$bin" segment --model "$model" --source "7scenes:$kitchen" --out "$work/seg" --every 10 --threads 1 2>&1 |
        sed -n 's/^forward pass: median \([0-9.]*\) ms.*/\1 ms/p')
  (cd models && PYTHONPATH=. /usr/bin/python3 -m edgefusion_models.agreement --tflite "$src/deeplabv3-mnv2-ade20k.tflite" \
    --model "$model" --source "7scenes:$kitchen" --every "$every" --edgefusion "$bin" --json "$work/a.json" >/dev/null 2>&1)
  read -r agree worst < <(/usr/bin/python3 -c "import json; a = json.load(open('$work/a.json')); \
print('%.2f%% %.2f%%' % (100 * a['agreement'], 100 * a['worst_frame_agreement']))")
  echo "| $size | $out | $macs | $fwd | $agree | $worst |"
done
echo
echo "Machine: $(lscpu | sed -n 's/^Model name: *//p'), $(nproc) cores; $(date -u +%Y-%m-%d)."
