#!/usr/bin/env python3
"""How much can fusing the CNN's views gain at all? A ceiling for SemanticFusion's Table I.

For every evaluated frame f of a sequence that `bench/semantic_table.py` rendered (its --work
folder), each pixel with known ground truth and depth is back-projected with the ground-truth pose
and projected into every frame g the CNN segmented (every K-th). Where g's depth agrees with the
point's (it is visible there, not occluded), g's CNN class is one vote for that pixel. The pixel
takes the class with the most votes (a tie goes to f's own CNN class); a pixel that no view sees
keeps f's CNN class. Two versions, as in Table I:
  vote now   the views up to and including f (what the online map could know when f arrived)
  vote end   every view of the sequence (what the finished map could know)
This is label fusion with perfect geometry (exact poses, no surfel association error) and one vote
per view: no mapper that fuses this CNN's per-view labels can correct an error that most views of
that point make, so the gap between "vote" and the CNN is what the fused map can hope to gain.

It also splits the CNN's errors: an error is "fixable" when most views of that point are right,
"shared" when most are wrong, in the same class or not.

The figures are computed here with numpy over the same pixels as `edgefusion eval labels --depth`
(pixels whose ground truth is unknown or whose depth is missing are left out). The rows CNN, SF and
SF end are read from the run's label folders (cnn/labels, sf/labels, sf/labels-end) and scored the
same way, so they reproduce semantic_table.py's figures: a check that the pixels are the same.
About 50 s per 1200-frame sequence (120 evaluated frames x 120 views) on one core.

  /usr/bin/python3 bench/fusion_ceiling.py --work /tmp/tab-loop [--sequences seed5001 ...] [--every 10]
"""
import argparse
import os
import sys

import cv2
import numpy as np

from semantic_table import CLASSES  # the 13 class names in id order 1..13 (bench/semantic_table.py)

NUM_IDS = 14  # 0 = unknown, 1..13 the classes
TUM_METRES_PER_UNIT = 1.0 / 5000.0


def read_list(path):
    """TUM list file -> [(timestamp, relative path)]."""
    rows = []
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            t, rel = line.split()[:2]
            rows.append((float(t), rel))
    return rows


def read_poses(path):
    """TUM trajectory -> {timestamp: (R 3x3 camera to world, t 3)}; '# lost' lines are ignored."""
    poses = {}
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            v = [float(x) for x in line.split()]
            t, (tx, ty, tz, qx, qy, qz, qw) = v[0], v[1:8]
            n = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
            qx, qy, qz, qw = qx / n, qy / n, qz / n, qw / n
            r = np.array([
                [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
                [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
                [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]])
            poses[round(t, 6)] = (r, np.array([tx, ty, tz]))
    return poses


def read_intrinsics(path):
    with open(path) as f:
        for line in f:
            if not line.startswith("#") and line.strip():
                return [float(x) for x in line.split()[:4]]
    sys.exit(f"fusion_ceiling: no intrinsics in {path}")


def imread(path, what):
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if img is None:
        sys.exit(f"fusion_ceiling: cannot read {what} {path}")
    return img


class Confusion:
    """Pixel counts per (ground truth, estimate) over the evaluated frames."""

    def __init__(self):
        self.m = np.zeros((NUM_IDS, NUM_IDS), np.int64)

    def add(self, gt, est):
        self.m += np.bincount(gt * NUM_IDS + est, minlength=NUM_IDS * NUM_IDS).reshape(NUM_IDS, NUM_IDS)

    def per_class(self):
        """Recall per class id 1..13 (None where the class has no ground-truth pixel)."""
        out = []
        for c in range(1, NUM_IDS):
            total = self.m[c].sum()
            out.append(None if total == 0 else 100.0 * self.m[c, c] / total)
        return out

    def class_average(self):
        v = [x for x in self.per_class() if x is not None]
        return sum(v) / len(v)


def ceiling(seq_dir, out_dir, every, depth_tol_m, depth_tol_rel):
    fx, fy, cx, cy = read_intrinsics(os.path.join(seq_dir, "intrinsics.txt"))
    rgb = read_list(os.path.join(seq_dir, "rgb.txt"))
    depth_list = read_list(os.path.join(seq_dir, "depth.txt"))
    poses = read_poses(os.path.join(seq_dir, "groundtruth.txt"))
    frames = list(range(0, len(rgb), every))
    stems = [os.path.splitext(os.path.basename(rgb[i][1]))[0] for i in frames]

    depth = {}
    cnn = {}
    for i, stem in zip(frames, stems):
        depth[i] = imread(os.path.join(seq_dir, depth_list[i][1]), "depth").astype(np.float32) * TUM_METRES_PER_UNIT
        cnn[i] = imread(os.path.join(out_dir, "cnn", "labels", stem + ".png"), "CNN labels")
    h, w = depth[frames[0]].shape
    vs, us = np.mgrid[0:h, 0:w]

    rows = {name: Confusion() for name in ("CNN", "vote now", "vote end", "SF", "SF end")}
    errors = np.zeros((NUM_IDS, 3), np.int64)  # per gt class: CNN errors fixable / shared-same / shared-other
    for f, stem in zip(frames, stems):
        gt = imread(os.path.join(seq_dir, "labels", stem + ".png"), "ground-truth labels")
        keep = (gt > 0) & (depth[f] > 0)
        gt_k = gt[keep].astype(np.int64)
        own = cnn[f][keep].astype(np.int64)
        z = depth[f][keep]
        pts = np.stack([(us[keep] - cx) / fx * z, (vs[keep] - cy) / fy * z, z], axis=1)
        r_f, t_f = poses[round(rgb[f][0], 6)]
        world = pts @ r_f.T + t_f

        votes = np.zeros((len(z), NUM_IDS), np.float32)
        votes[np.arange(len(z)), own] += 0.5  # breaks ties towards f's own class
        correct_views = np.zeros(len(z), np.int32)
        seen_views = np.zeros(len(z), np.int32)
        now = None
        for g in frames:
            r_g, t_g = poses[round(rgb[g][0], 6)]
            cam = (world - t_g) @ r_g  # world -> camera g (R^T (X - t)), as row vectors
            zg = cam[:, 2]
            ok = zg > 0.1
            u = np.full(len(z), -1, np.int64)
            v = np.full(len(z), -1, np.int64)
            u[ok] = np.round(cam[ok, 0] / zg[ok] * fx + cx).astype(np.int64)
            v[ok] = np.round(cam[ok, 1] / zg[ok] * fy + cy).astype(np.int64)
            ok &= (u >= 0) & (u < w) & (v >= 0) & (v < h)
            idx = np.nonzero(ok)[0]
            d = depth[g][v[idx], u[idx]]
            vis = (d > 0) & (np.abs(d - zg[idx]) < depth_tol_m + depth_tol_rel * zg[idx])
            idx = idx[vis]
            lab = cnn[g][v[idx], u[idx]].astype(np.int64)
            votes[idx, lab] += 1.0
            seen_views[idx] += 1
            correct_views[idx] += (lab == gt_k[idx])
            if g == f:
                now = np.argmax(votes, axis=1)
        end = np.argmax(votes, axis=1)

        rows["CNN"].add(gt_k, own)
        rows["vote now"].add(gt_k, now)
        rows["vote end"].add(gt_k, end)
        for name, folder in (("SF", "labels"), ("SF end", "labels-end")):
            path = os.path.join(out_dir, "sf", folder, stem + ".png")
            if os.path.exists(path):
                rows[name].add(gt_k, imread(path, name + " labels")[keep].astype(np.int64))

        wrong = own != gt_k
        majority_right = 2 * correct_views > seen_views
        end_same_as_own = end == own
        np.add.at(errors, (gt_k[wrong & majority_right], 0), 1)
        np.add.at(errors, (gt_k[wrong & ~majority_right & end_same_as_own], 1), 1)
        np.add.at(errors, (gt_k[wrong & ~majority_right & ~end_same_as_own], 2), 1)
    return rows, errors


def fmt(x):
    return "-" if x is None else f"{x:.1f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--work", required=True, help="bench/semantic_table.py's --work folder")
    ap.add_argument("--sequences", nargs="*", help="sequence folders in --work; default every one with an out-<name>")
    ap.add_argument("--every", type=int, default=10, help="evaluated and segmented every K-th frame; default 10")
    ap.add_argument("--depth-tolerance", type=float, nargs=2, default=[0.05, 0.02], metavar=("M", "REL"),
                    help="a view sees the point when |depth - projected depth| < M + REL * depth; default 0.05 m, 0.02")
    args = ap.parse_args()

    names = args.sequences or sorted(d[len("out-"):] for d in os.listdir(args.work) if d.startswith("out-"))
    if not names:
        sys.exit(f"fusion_ceiling: no out-<sequence> folders in {args.work}; run bench/semantic_table.py first")
    header = "| sequence | method | " + " | ".join(CLASSES) + " | class avg |"
    print(header)
    print("|" + "---|" * (len(CLASSES) + 3))
    summary = {}
    all_errors = np.zeros((NUM_IDS, 3), np.int64)
    for name in names:
        rows, errors = ceiling(os.path.join(args.work, name), os.path.join(args.work, "out-" + name), args.every,
                               *args.depth_tolerance)
        all_errors += errors
        for method, conf in rows.items():
            if conf.m.sum() == 0:
                continue
            print(f"| {name} | {method} | " + " | ".join(fmt(x) for x in conf.per_class()) +
                  f" | {conf.class_average():.1f} |")
            summary.setdefault(method, []).append(conf.class_average())
        sys.stdout.flush()
    print()
    cnn = np.mean(summary["CNN"])
    for method, values in summary.items():
        gain = "" if method == "CNN" else f" ({np.mean(values) - cnn:+.1f})"
        print(f"class average, mean of {len(values)} sequences, {method}: {np.mean(values):.1f}{gain}")
    print()
    print("CNN errors by what the other views of the same point say (all sequences):")
    print("| class | CNN errors (px) | fixable: most views right | shared, fused end keeps the CNN's class |"
          " shared, another wrong class |")
    print("|---|---:|---:|---:|---:|")
    for c in range(1, NUM_IDS):
        n = all_errors[c].sum()
        if n:
            p = 100.0 * all_errors[c] / n
            print(f"| {CLASSES[c - 1]} | {n} | {p[0]:.1f}% | {p[1]:.1f}% | {p[2]:.1f}% |")
    n = all_errors.sum()
    p = 100.0 * all_errors.sum(axis=0) / n
    print(f"| all | {n} | {p[0]:.1f}% | {p[1]:.1f}% | {p[2]:.1f}% |")


if __name__ == "__main__":
    main()
