"""Accuracy of the shipped model on the held-out test sequences (seeds 7001.., dataset.py), at the
working resolution 320x240, for the model card.

    /usr/bin/python3 -m edgefusion_models.evaluate --edgefusion BIN --model edgefusion-seg.efm \
        --checkpoint checkpoints/edgesegnet.pt --data-dir /tmp/edgefusion-data [--markdown FILE]

int8: each test sequence is written at 320x240 by `edgefusion convert`, segmented by
`edgefusion segment` (the C++ runtime: resample to 160x120, int8 forward pass, labels upsampled by
nearest neighbour to 320x240) and compared with the 320x240 ground-truth labels.
float: the PyTorch float model on the same sequences' 160x120 frames (test.npz), its labels
upsampled by nearest neighbour to 320x240 in the same way.
Pixels with unknown ground truth are not counted (as `edgefusion eval labels`).
"""
import argparse
import json
import os
import subprocess

import cv2
import numpy as np
import torch

from . import dataset
from .net import CLASS_NAMES, NUM_CLASSES, EdgeSegNet
from .train import confusion, metrics, to_input


def render_320(edgefusion, seed, root):
    folder = os.path.join(root, f"seed{seed:05d}")
    if not os.path.exists(os.path.join(folder, "done")):
        subprocess.run([edgefusion, "convert", "--source", dataset.sequence_uri(seed), "--to", "tum:" + folder],
                       check=True, stdout=subprocess.DEVNULL)
        open(os.path.join(folder, "done"), "w").close()
    return folder


def read_labels(folder):
    names = sorted(f for f in os.listdir(folder) if f.endswith(".png"))
    return np.stack([cv2.imread(os.path.join(folder, n), cv2.IMREAD_UNCHANGED) for n in names])


def upsample_nearest_x2(labels):
    return labels.repeat(2, axis=1).repeat(2, axis=2)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--edgefusion", required=True)
    ap.add_argument("--model", required=True)
    ap.add_argument("--checkpoint", required=True)
    ap.add_argument("--data-dir", default="/tmp/edgefusion-data")
    ap.add_argument("--also-model", default="", help="a second .efm (e.g. the ONNX import) in its own column")
    ap.add_argument("--json", default="", help="write the figures here")
    args = ap.parse_args()

    root = os.path.join(args.data_dir, "test320")
    models = [args.model] + ([args.also_model] if args.also_model else [])
    cms = [np.zeros((NUM_CLASSES, NUM_CLASSES), np.int64) for _ in models]
    gts = []
    for seed in dataset.SPLIT_SEEDS["test"]:
        folder = render_320(args.edgefusion, seed, root)
        gt = read_labels(os.path.join(folder, "labels"))
        gts.append(gt)
        for k, model in enumerate(models):
            out = os.path.join(root, f"segment{k}", f"seed{seed:05d}")
            subprocess.run([args.edgefusion, "segment", "--model", model, "--source", "tum:" + folder,
                            "--out", out, "--quiet"], check=True, stdout=subprocess.DEVNULL)
            est = read_labels(os.path.join(out, "labels"))
            if gt.shape != est.shape:
                raise RuntimeError(f"seed {seed}: ground truth {gt.shape} and estimate {est.shape} differ")
            cms[k] += confusion(est, gt)
    gt_all = np.concatenate(gts)

    rgb, depth, _ = dataset.build_split(args.edgefusion, "test", args.data_dir)
    net = EdgeSegNet()
    net.load_state_dict(torch.load(args.checkpoint, map_location="cpu")["model"])
    net.eval()
    preds = []
    with torch.no_grad():
        for i in range(0, rgb.shape[0], 32):
            preds.append(net(to_input(rgb[i:i + 32], depth[i:i + 32])).argmax(1).numpy().astype(np.uint8))
    cm_float = confusion(upsample_nearest_x2(np.concatenate(preds)), gt_all)

    mf = metrics(cm_float)
    mis = [metrics(cm) for cm in cms]
    print(f"test: {gt_all.shape[0]} frames at {gt_all.shape[2]}x{gt_all.shape[1]}, "
          f"{len(dataset.SPLIT_SEEDS['test'])} sequences (seeds {min(dataset.SPLIT_SEEDS['test'])}.."
          f"{max(dataset.SPLIT_SEEDS['test'])})")
    heads = ["float (PyTorch)", "int8 (C++ runtime)"] + (["int8, ONNX import (C++ runtime)"] if args.also_model else [])
    print("| class | pixels | " + " | ".join(heads) + " |\n|---|---:|" + "---:|" * len(heads))
    rows = cms[0].sum(1)
    for c in range(1, NUM_CLASSES):
        if rows[c] == 0:
            print(f"| {CLASS_NAMES[c]} | 0 |" + " - |" * len(heads))
            continue
        vals = [mf] + mis
        print(f"| {CLASS_NAMES[c]} | {rows[c]} | " + " | ".join(f"{100 * m['per_class'][c]:.1f}" for m in vals) + " |")
    for key, name in (("class_average", "class average"), ("pixel_average", "pixel average"), ("miou", "mIoU")):
        print(f"| **{name}** | | " + " | ".join(f"{100 * m[key]:.1f}" for m in [mf] + mis) + " |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"float": mf, "int8": mis[0], "int8_also": mis[1] if args.also_model else None,
                       "frames": int(gt_all.shape[0])}, f, indent=1)


if __name__ == "__main__":
    main()
