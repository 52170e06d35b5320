#!/usr/bin/python3
"""A few labelled frames side by side: colour, the single-frame CNN's labels, the fused map's labels.

  /usr/bin/python3 bench/draw_label_frames.py --data DIR --segment SEG/labels --fused OUT/labels
      --out PICTURE.png [--frames 100,350,600,850] [--title TEXT] [--size 320x240]

DIR: a 7-Scenes folder (frame-NNNNNN.color.jpg); SEG/labels: `edgefusion segment --out SEG`'s class-id
PNGs; OUT/labels: `edgefusion run --labels-out` class-id PNGs (the map as it was when the frame
arrived, the CNN's own label where the map shows no labelled surfel). One row per frame, drawn at
--size (colour area-averaged, labels by nearest neighbour), in the NYUv2 13-class palette, with a
legend of the classes that appear. The label columns also give the share of pixels on which the two
label images agree.
"""
import argparse
import os
import sys

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from draw_map import BACKGROUND, CLASS_NAMES, PALETTE, legend, put_text, write_png  # noqa: E402


def load_labels(path, size):
    lab = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if lab is None:
        raise SystemExit("missing " + path)
    if lab.ndim == 3:
        lab = lab[:, :, 0]
    if (lab.shape[1], lab.shape[0]) != size:
        lab = cv2.resize(lab, size, interpolation=cv2.INTER_NEAREST)
    return lab


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--segment", required=True, help="folder of the CNN's class-id PNGs")
    ap.add_argument("--fused", required=True, help="folder of the run's --labels-out PNGs")
    ap.add_argument("--out", required=True)
    ap.add_argument("--frames", default="100,350,600,850")
    ap.add_argument("--title")
    ap.add_argument("--size", default="320x240")
    a = ap.parse_args()
    W, H = (int(t) for t in a.size.split("x"))
    rows, present = [], set()
    for i in (int(t) for t in a.frames.split(",")):
        stem = "frame-%06d" % i
        bgr = cv2.imread(os.path.join(a.data, stem + ".color.jpg"))
        if bgr is None:
            raise SystemExit("missing colour of " + stem)
        colour = cv2.resize(bgr, (W, H), interpolation=cv2.INTER_AREA)[:, :, ::-1].copy()
        cnn = load_labels(os.path.join(a.segment, stem + ".png"), (W, H))
        fused = load_labels(os.path.join(a.fused, stem + ".png"), (W, H))
        present |= set(np.unique(cnn).tolist()) | set(np.unique(fused).tolist())
        agree = float(np.mean(cnn == fused))
        panels = [colour, PALETTE[np.clip(cnn, 0, 13)], PALETTE[np.clip(fused, 0, 13)]]
        put_text(panels[0], "frame %d" % i, (6, 18), 0.5)
        put_text(panels[1], "CNN, this frame", (6, 18), 0.5)
        put_text(panels[2], "fused map (agree %.0f%%)" % (100 * agree), (6, 18), 0.5)
        sep = np.full((H, 3, 3), 255, np.uint8)
        rows.append(np.concatenate([panels[0], sep, panels[1], sep, panels[2]], axis=1))
        rows.append(np.full((3, rows[-1].shape[1], 3), 255, np.uint8))
    body = np.concatenate(rows[:-1], axis=0)
    parts = []
    if a.title:
        head = np.zeros((28, body.shape[1], 3), np.uint8)
        head[:] = BACKGROUND
        put_text(head, a.title, (8, 19), 0.5)
        parts.append(head)
    parts += [body, legend(body.shape[1], sorted(c for c in present if 0 <= c <= 13), col_w=135)]
    nbytes, bits = write_png(a.out, np.concatenate(parts, axis=0))
    print("%s: %d bytes (%d bits/channel), classes: %s" %
          (a.out, nbytes, bits, ", ".join(CLASS_NAMES[c] for c in sorted(present) if c <= 13)))


if __name__ == "__main__":
    main()
