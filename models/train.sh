#!/usr/bin/env bash
# One command, from a fresh Debian 12 machine (as root): installs what training needs, builds the
# edgefusion binary (it renders the synthetic training data and runs the int8 evaluation), trains
# EdgeSegNet, quantises and exports it to models/edgefusion-seg.efm with its golden tensors, exports
# it to ONNX and imports that through `edgefusion model import` (the bring-your-own-model path), and
# prints the accuracy table of the model card (float, native int8 export, ONNX import).
#   EF_TRAIN_DATA=<dir>   rendered data and caches (default /tmp/edgefusion-data, about 1 GB)
#   EF_TRAIN_EPOCHS=<n>   epochs (default 14, the shipped model's recipe)
#   EF_TRAIN_THREADS=<n>  PyTorch threads (default 1: results depend on the thread count)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh models
cmake -S . -B build/models -G Ninja -DCMAKE_BUILD_TYPE=Release -DEF_BUILD_TESTS=OFF -DEF_BUILD_BENCH=OFF >/dev/null
cmake --build build/models --target edgefusion
bin="$PWD/build/models/firmware_app/edgefusion"
data="${EF_TRAIN_DATA:-/tmp/edgefusion-data}"
cd models
start=$(date +%s)
/usr/bin/python3 -m edgefusion_models.train --edgefusion "$bin" --data-dir "$data" \
  --out checkpoints/edgesegnet.pt --epochs "${EF_TRAIN_EPOCHS:-14}" --threads "${EF_TRAIN_THREADS:-1}"
/usr/bin/python3 -m edgefusion_models.export --checkpoint checkpoints/edgesegnet.pt \
  --calibration-npz "$data/val.npz" --out edgefusion-seg.efm --golden-dir golden
/usr/bin/python3 -m edgefusion_models.to_onnx --checkpoint checkpoints/edgesegnet.pt --out "$data/edgesegnet.onnx"
"$bin" model import --onnx "$data/edgesegnet.onnx" --calibration "npz:$data/val.npz" --frames 128 \
  --out "$data/edgesegnet-onnx.efm"
/usr/bin/python3 -m edgefusion_models.evaluate --edgefusion "$bin" --model edgefusion-seg.efm \
  --also-model "$data/edgesegnet-onnx.efm" --checkpoint checkpoints/edgesegnet.pt --data-dir "$data" \
  --json checkpoints/evaluation.json
echo "models/train.sh: done in $(( ($(date +%s) - start) / 60 )) min"
