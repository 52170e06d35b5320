#!/usr/bin/env bash
# One command that reproduces the shipped real-camera model byte for byte (on one machine: the
# calibration runs float numpy, whose last bits may differ between CPUs and BLAS builds):
# DeepLabv3-MobileNetV2 trained on ADE20K (../shared/models/deeplabv3-mnv2-ade20k, a TFLite file)
# imported at 257x193, its 151 classes mapped to the NYUv2 13 inside the model, calibrated on 40
# real 7-Scenes kitchen frames (the middle frames of 40 equal segments: 12, 37, 62, ..., 987, none of
# them one of the every-10th frames the agreement with the float network is measured on; synthetic
# rooms in the calibration cost 0.6 points of that agreement), with its golden files. Writes
# models/deeplabv3-mnv2-nyu13.efm and models/golden-deeplab/.
#   EF_SHARED=<dir>   the shared folder (default ../shared beside the repository)
set -euo pipefail
cd "$(dirname "$0")/.."
shared="$(realpath "${EF_SHARED:-../shared}")"
src="$shared/models/deeplabv3-mnv2-ade20k"
for f in "$src/deeplabv3-mnv2-ade20k.tflite" "$src/ade20k_to_nyu13.json" "$src/ade20k-labels.txt" \
         "$shared/data/7scenes-redkitchen"; do
  [ -e "$f" ] || { echo "models/import_deeplab.sh: $f not found (set EF_SHARED)" >&2; exit 1; }
done
bash scripts/install-deps.sh models
cmake -S . -B build/models -G Ninja -DCMAKE_BUILD_TYPE=Release -DEF_BUILD_TESTS=OFF -DEF_BUILD_BENCH=OFF >/dev/null
cmake --build build/models --target edgefusion
start=$(date +%s)
# One BLAS thread: sums in one order, so the calibration's float results (and the file) do not depend
# on how many cores the machine has.
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
build/models/firmware_app/edgefusion model import --tflite "$src/deeplabv3-mnv2-ade20k.tflite" \
  --input 257x193 --class-map "$src/ade20k_to_nyu13.json" --labels "$src/ade20k-labels.txt" \
  --calibration "7scenes:$shared/data/7scenes-redkitchen" \
  --frames 40 --out models/deeplabv3-mnv2-nyu13.efm --golden-dir models/golden-deeplab
sha256sum models/deeplabv3-mnv2-nyu13.efm
echo "models/import_deeplab.sh: done in $(( $(date +%s) - start )) s"
