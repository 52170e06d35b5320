"""Trains EdgeSegNet on the synthetic rooms (see dataset.py for the splits).

    /usr/bin/python3 -m edgefusion_models.train --edgefusion build/release/firmware_app/edgefusion \
        --data-dir /tmp/edgefusion-data --out models/checkpoints/edgesegnet.pt

Renders the data on first use, trains on CPU (or CUDA when present), keeps the checkpoint with the
best validation class-average accuracy, and prints the per-epoch figures and the run time.
Deterministic for a given --seed and thread count on the same machine.
"""
import argparse
import json
import os
import time

import numpy as np
import torch
import torch.nn.functional as F

from . import dataset
from .net import DEPTH_MAX_M, INPUT_MEAN, INPUT_SCALE, NUM_CLASSES, EdgeSegNet, count_macs


def to_input(rgb, depth):
    """Raw uint8 RGB (N,H,W,3) and depth in metres (N,H,W) -> normalised float tensor (N,4,H,W)."""
    x = np.concatenate([rgb.astype(np.float32), np.minimum(depth, DEPTH_MAX_M)[..., None]], axis=3)
    x = (x - np.float32(INPUT_MEAN)) * np.float32(INPUT_SCALE)
    return torch.from_numpy(np.ascontiguousarray(x.transpose(0, 3, 1, 2)))


def augment(rgb, depth, labels, rng):
    """Lighting (per-image gain and offset per channel) and horizontal flips; depth is untouched
    apart from the flip, so the depth channel keeps its metric meaning. `labels`: class ids N x H x W,
    or per-pixel targets N x h x w x C on a grid of its own (distill.py's teacher probabilities):
    flipped with the frame either way."""
    n = rgb.shape[0]
    gain = rng.uniform(0.75, 1.25, size=(n, 1, 1, 1)) * rng.uniform(0.9, 1.1, size=(n, 1, 1, 3))
    offset = rng.uniform(-20, 20, size=(n, 1, 1, 1))
    rgb = np.clip(rgb.astype(np.float32) * gain + offset, 0, 255).astype(np.uint8)
    flip = rng.random(n) < 0.5
    rgb[flip] = rgb[flip, :, ::-1]
    depth = depth.copy()
    depth[flip] = depth[flip, :, ::-1]
    labels = labels.copy()
    labels[flip] = labels[flip, :, ::-1]
    return rgb, depth, labels


def confusion(pred, labels, num_classes=NUM_CLASSES):
    """Confusion counts [gt][pred] over pixels with known ground truth (label != 0)."""
    keep = labels > 0
    idx = labels[keep].astype(np.int64) * num_classes + pred[keep].astype(np.int64)
    return np.bincount(idx, minlength=num_classes * num_classes).reshape(num_classes, num_classes)


def metrics(cm):
    """Class-average and pixel-average accuracy and mIoU over the classes present (1..13)."""
    rows = cm.sum(1)
    present = [c for c in range(1, cm.shape[0]) if rows[c] > 0]
    acc = {c: cm[c, c] / rows[c] for c in present}
    iou = {c: cm[c, c] / (rows[c] + cm[:, c].sum() - cm[c, c]) for c in present}
    return {"class_average": float(np.mean(list(acc.values()))),
            "pixel_average": float(sum(cm[c, c] for c in present) / rows[present].sum()),
            "miou": float(np.mean(list(iou.values()))),
            "per_class": {int(c): float(a) for c, a in acc.items()}}


def evaluate(model, rgb, depth, labels, batch=32):
    model.eval()
    cm = np.zeros((NUM_CLASSES, NUM_CLASSES), np.int64)
    with torch.no_grad():
        for i in range(0, rgb.shape[0], batch):
            logits = model(to_input(rgb[i:i + batch], depth[i:i + batch]))
            cm += confusion(logits.argmax(1).numpy(), labels[i:i + batch])
    return metrics(cm)


def class_weights(labels):
    """Square root of median-frequency balancing over classes 1..13 (unknown gets weight 0): small
    classes (books, paintings, tv) count more without drowning the large ones."""
    freq = np.bincount(labels.ravel(), minlength=NUM_CLASSES).astype(np.float64)
    freq = freq / freq.sum()
    w = np.zeros(NUM_CLASSES)
    seen = freq[1:] > 0
    med = np.median(freq[1:][seen])
    w[1:][seen] = np.sqrt(med / freq[1:][seen])
    return torch.tensor(w, dtype=torch.float32)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--edgefusion", required=True, help="path of the edgefusion binary (renders the data)")
    ap.add_argument("--data-dir", default="/tmp/edgefusion-data", help="rendered sequences and npz caches")
    ap.add_argument("--out", default="models/checkpoints/edgesegnet.pt", help="best checkpoint")
    ap.add_argument("--epochs", type=int, default=14)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--lr", type=float, default=3e-3, help="peak learning rate (AdamW, cosine decay)")
    ap.add_argument("--weight-decay", type=float, default=1e-4)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--camera", choices=["ideal", "kinect"], default="ideal",
                    help="colour camera of the synthetic data (synthetic source's camera=); give each its own --data-dir")
    ap.add_argument("--layout", choices=["walls", "island"], default="walls",
                    help="room layout of the hand-held sequences (synthetic source's layout=); give each its own --data-dir")
    ap.add_argument("--handheld", choices=["loop", "inspect"], default="loop",
                    help="inspect: half the hand-held sequences turn to the near wall and back (synthetic source's "
                         "trajectory=inspect); give each its own --data-dir")
    args = ap.parse_args()

    t_start = time.time()
    torch.manual_seed(args.seed)
    torch.set_num_threads(args.threads)
    rng = np.random.default_rng(args.seed)
    device = "cuda" if torch.cuda.is_available() else "cpu"

    train = dataset.build_split(args.edgefusion, "train", args.data_dir, camera=args.camera, layout=args.layout, handheld=args.handheld)
    val = dataset.build_split(args.edgefusion, "val", args.data_dir, camera=args.camera, layout=args.layout, handheld=args.handheld)
    print(f"data: {train[0].shape[0]} training frames, {val[0].shape[0]} validation frames "
          f"({time.time() - t_start:.0f} s)", flush=True)

    model = EdgeSegNet().to(device)
    print(f"EdgeSegNet: {count_macs(model) / 1e6:.1f} MMAC, "
          f"{sum(p.numel() for p in model.parameters())} parameters", flush=True)
    weights = class_weights(train[2]).to(device)
    opt = torch.optim.AdamW(model.parameters(), lr=args.lr, weight_decay=args.weight_decay)
    n = train[0].shape[0]
    steps = args.epochs * (n // args.batch)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=args.lr, total_steps=steps, pct_start=0.1)

    best = None
    history = []
    for epoch in range(args.epochs):
        model.train()
        t0 = time.time()
        order = rng.permutation(n)
        total = 0.0
        for b in range(n // args.batch):
            sel = np.sort(order[b * args.batch:(b + 1) * args.batch])
            rgb, depth, labels = augment(train[0][sel], train[1][sel], train[2][sel], rng)
            x = to_input(rgb, depth).to(device)
            y = torch.from_numpy(labels.astype(np.int64)).to(device)
            loss = F.cross_entropy(model(x), y, weight=weights, ignore_index=0)
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            total += loss.item()
        m = evaluate(model.cpu(), *val)
        model.to(device)
        history.append({"epoch": epoch + 1, "loss": total / (n // args.batch), **{k: m[k] for k in
                        ("class_average", "pixel_average", "miou")}})
        print(f"epoch {epoch + 1}/{args.epochs}: loss {history[-1]['loss']:.4f}  val class avg "
              f"{100 * m['class_average']:.1f}%  pixel avg {100 * m['pixel_average']:.1f}%  mIoU "
              f"{100 * m['miou']:.1f}%  ({time.time() - t0:.0f} s)", flush=True)
        if best is None or m["class_average"] > best["class_average"]:
            best = {**m, "epoch": epoch + 1}
            os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
            torch.save({"model": model.state_dict(), "epoch": epoch + 1, "val": m, "args": vars(args)}, args.out)

    run_s = time.time() - t_start
    print(f"best: epoch {best['epoch']}, val class avg {100 * best['class_average']:.1f}%, pixel avg "
          f"{100 * best['pixel_average']:.1f}%; total run time {run_s / 60:.1f} min on {device} "
          f"with {args.threads} threads", flush=True)
    with open(os.path.splitext(args.out)[0] + "_history.json", "w") as f:
        json.dump({"history": history, "best": best, "run_time_s": run_s, "device": device,
                   "threads": args.threads, "args": vars(args)}, f, indent=1)


if __name__ == "__main__":
    main()
