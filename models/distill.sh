#!/usr/bin/env bash
# Distils the real-camera network (deeplabv3-mnv2-nyu13.efm, the teacher) into EdgeSegNet (the
# student: RGB-D, 160x120, 59 MMAC, 40x fewer multiply-adds) on a real recording, and measures the
# int8 student against the teacher on the frames it never trained on (issue 28, item 8;
# edgefusion_models/distill.py says how). One command, from the repository root:
#   bash models/distill.sh [SOURCE_URI] [HOLDOUT_FROM]
# Defaults: the 7-Scenes kitchen of ../shared (1000 frames), frames 700.. held out. Any recording
# works the same way, a robot's own field logs (mcap:FILE) among them: the student then learns the
# teacher's labels for the places that robot maps.
#   EF_DISTILL_DIR=<dir>   work folder and outputs (default /tmp/edgefusion-distill): student.pt, its
#                          int8 student.efm, the figures in evaluation.json
#   EF_TRAIN_DATA=<dir>    the synthetic rooms (train.sh's, rendered here if absent; default /tmp/edgefusion-data)
#   EF_DISTILL_EPOCHS=<n>  epochs (default 12)
#   EF_DISTILL_DEVICE=<d>  cpu (default: one thread, deterministic, the figures in docs/results.md),
#                          cuda or auto (a GPU where PyTorch sees one; models/distill_sweep.sh trains
#                          several students at once on a GPU machine without the binary)
# The student is not shipped: the 7-Scenes frames it learns from are for research use only
# (../shared/data/7scenes-redkitchen/README.txt).
set -euo pipefail
cd "$(dirname "$0")/.."
source="${1:-7scenes:$(realpath ../shared/data/7scenes-redkitchen)}"
holdout="${2:-700}"
work="${EF_DISTILL_DIR:-/tmp/edgefusion-distill}"
bash scripts/install-deps.sh models
cmake -S . -B build/models -G Ninja -DCMAKE_BUILD_TYPE=Release -DEF_BUILD_TESTS=OFF -DEF_BUILD_BENCH=OFF >/dev/null
cmake --build build/models --target edgefusion
bin="$PWD/build/models/firmware_app/edgefusion"
mkdir -p "$work"
start=$(date +%s)
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1
cd models
/usr/bin/python3 -m edgefusion_models.distill --edgefusion "$bin" --teacher deeplabv3-mnv2-nyu13.efm \
  --source "$source" --holdout-from "$holdout" --work-dir "$work" --out "$work/student.pt" \
  --synthetic-dir "${EF_TRAIN_DATA:-/tmp/edgefusion-data}" --epochs "${EF_DISTILL_EPOCHS:-12}" \
  --device "${EF_DISTILL_DEVICE:-cpu}"
/usr/bin/python3 -m edgefusion_models.export --checkpoint "$work/student.pt" \
  --calibration-npz "$work/student_calibration.npz" --out "$work/student.efm" --golden-dir "$work/golden"
/usr/bin/python3 -m edgefusion_models.distill --evaluate --edgefusion "$bin" --teacher deeplabv3-mnv2-nyu13.efm \
  --student "$work/student.efm" --baseline edgefusion-seg.efm --source "$source" --holdout-from "$holdout" \
  --work-dir "$work" --json "$work/evaluation.json"
echo "models/distill.sh: done in $(( ($(date +%s) - start) / 60 )) min; the student: $work/student.efm"
