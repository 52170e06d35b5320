#!/usr/bin/python3
"""Label stability on a 7-Scenes recording: the single-frame CNN against the fused map.

Question: over the recording, how often does a surface point's label change between consecutive
labelled views?  For the single-frame CNN (`edgefusion segment --every K`) and for the fused map
rendered at the same frames as they arrive (`edgefusion run --labels-out ... --deterministic`).

Method, for each pair of labelled frames (i, i+gap):
  * frame i's depth is brought to the label images' resolution (default 320x240) by taking one
    source pixel per label pixel (the one just below and right of the block's centre, i.e. source pixel
    (2u+1, 2v+1) for a factor 2, back-projected at its exact position u+0.25 in the label grid);
    intrinsics are scaled with the half-pixel-centre convention: c' = (c + 0.5) * s - 0.5;
  * pixels with valid depth (0 and 65535 are invalid) are back-projected with frame i's pose to
    world points and projected into frame i+gap with its pose;
  * a point is co-visible when it lands inside the image, frame i+gap has valid depth there and
    |z_projected - depth_{i+gap}| < 5 cm (the same surface seen from both views);
  * among co-visible points whose label is known (not 0) in both views, count those whose label
    differs.  Points labelled 0 in either view are counted separately.
The CNN's labels (written at the source size) are sampled at the same source pixel as the depth,
so both label sources are measured on exactly the same points.
Poses: the run's own trajectory (trajectory.txt, TUM, matched to frames by order after checking the
timestamps against index/30) and, as a check, the reference poses (frame-NNNNNN.pose.txt).

One command:
  /usr/bin/python3 bench/label_stability.py [--edgefusion BIN] [--data DIR] [--work DIR]
      [--model FILE] [--every 10] [--gaps 10,50] [--reuse] [--json FILE]
runs `edgefusion run` and `edgefusion segment` into --work (skipped with --reuse when their outputs
are there), prints a table and writes JSON (default WORK/label_stability.json).
"""
import argparse
import json
import os
import subprocess
import sys
import time

import cv2
import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TOLERANCE_M = 0.05


def read_intrinsics(data_dir):
    path = os.path.join(data_dir, "camera-intrinsics.txt")
    if not os.path.exists(path):
        return 585.0, 585.0, 320.0, 240.0
    m = np.loadtxt(path)
    return float(m[0, 0]), float(m[1, 1]), float(m[0, 2]), float(m[1, 2])


def frame_stems(data_dir):
    stems = sorted(f[: -len(".color.jpg")] for f in os.listdir(data_dir) if f.endswith(".color.jpg"))
    return stems


def quat_to_matrix(qx, qy, qz, qw):
    n = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    x, y, z, w = qx / n, qy / n, qz / n, qw / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def read_tum_trajectory(path):
    """Poses in file order; returns (timestamps, 4x4 poses, set of indices preceded by '# lost')."""
    stamps, poses, lost = [], [], set()
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            if line.startswith("#"):
                if line.startswith("# lost"):
                    lost.add(len(poses))
                continue
            v = [float(t) for t in line.split()]
            T = np.eye(4)
            T[:3, :3] = quat_to_matrix(v[4], v[5], v[6], v[7])
            T[:3, 3] = v[1:4]
            stamps.append(v[0])
            poses.append(T)
    return np.array(stamps), poses, lost


def run(cmd, log):
    t0 = time.time()
    with open(log, "w") as f:
        f.write(" ".join(cmd) + "\n")
        f.flush()
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    dt = time.time() - t0
    if r.returncode != 0:
        sys.exit("failed (%d): %s (see %s)" % (r.returncode, " ".join(cmd), log))
    return dt


def load_depth_m(path, step):
    d = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    o = step // 2  # the source pixel at (or just past) the block centre
    d = d[o::step, o::step].astype(np.float64)
    d[(d == 0) | (d == 65535)] = 0
    return d / 1000.0


def load_labels(path, shape, step):
    lab = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if lab is None:
        raise SystemExit("missing label image " + path)
    if lab.ndim == 3:
        lab = lab[:, :, 0]
    if lab.shape != shape:  # at the source size: the same source pixel as the depth sample
        o = step // 2
        lab = lab[o::step, o::step]
    assert lab.shape == shape, (path, lab.shape, shape)
    return lab


_boundary_cache = {}


def boundary(lab):
    """Pixels within 2 of a different label (5x5 window holds more than one class)."""
    key = id(lab)
    if key not in _boundary_cache:
        k = np.ones((5, 5), np.uint8)
        _boundary_cache[key] = (cv2.dilate(lab, k) != cv2.erode(lab, k), lab)
    return _boundary_cache[key][0]


def pair_stats(di, dj, Ti, Tj, K, labels_i, labels_j):
    fx, fy, cx, cy, off = K
    h, w = di.shape
    v, u = np.nonzero(di > 0)
    z = di[v, u]
    x = (u + off - cx) / fx * z
    y = (v + off - cy) / fy * z
    P = np.stack([x, y, z, np.ones_like(z)])
    Q = (np.linalg.inv(Tj) @ Ti @ P)[:3]
    front = Q[2] > 1e-6
    uj = np.full(z.shape, -1, np.int64)
    vj = np.full(z.shape, -1, np.int64)
    # continuous position in the label grid -> the nearest grid pixel (the depth sample sits at +off)
    uj[front] = np.rint(Q[0, front] / Q[2, front] * fx + cx - off).astype(np.int64)
    vj[front] = np.rint(Q[1, front] / Q[2, front] * fy + cy - off).astype(np.int64)
    inside = front & (uj >= 0) & (uj < w) & (vj >= 0) & (vj < h)
    ok = np.zeros(z.shape, bool)
    dz = dj[vj[inside], uj[inside]]
    ok[inside] = (dz > 0) & (np.abs(Q[2, inside] - dz) < TOLERANCE_M)
    res = {"valid_depth": int(z.size), "covisible": int(ok.sum())}
    for name, li in labels_i.items():
        a = li[v[ok], u[ok]]
        b = labels_j[name][vj[ok], uj[ok]]
        known = (a != 0) & (b != 0)
        # interior: away (> 2 label pixels) from a label boundary in both views, where a small
        # misregistration of poses, depth or colour cannot change the label by itself
        inner = known & ~boundary(li)[v[ok], u[ok]] & ~boundary(labels_j[name])[vj[ok], uj[ok]]
        res[name] = {"known": int(known.sum()), "unknown_either": int((~known).sum()),
                     "changed": int((a[known] != b[known]).sum()),
                     "interior": int(inner.sum()), "interior_changed": int((a[inner] != b[inner]).sum())}
    return res


def summarise(pairs, names):
    out = {"pairs": len(pairs), "covisible_points": int(sum(p["covisible"] for p in pairs))}
    for n in names:
        known = np.array([p[n]["known"] for p in pairs], np.float64)
        changed = np.array([p[n]["changed"] for p in pairs], np.float64)
        unk = int(sum(p[n]["unknown_either"] for p in pairs))
        use = known > 0
        out[n] = {
            "changed_share_mean_over_pairs": float(np.mean(changed[use] / known[use])) if use.any() else None,
            "changed_share_median_over_pairs": float(np.median(changed[use] / known[use])) if use.any() else None,
            "changed_share_pooled": float(changed.sum() / known.sum()) if known.sum() else None,
            "points_known_both": int(known.sum()),
            "points_changed": int(changed.sum()),
            "points_unknown_in_either": unk,
            "interior_points": int(sum(p[n]["interior"] for p in pairs)),
            "interior_changed_share_pooled": float(sum(p[n]["interior_changed"] for p in pairs) /
                                                   max(sum(p[n]["interior"] for p in pairs), 1)),
        }
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--edgefusion", default=os.path.join(REPO, "build/release/firmware_app/edgefusion"))
    ap.add_argument("--data", default=os.path.normpath(os.path.join(REPO, "../shared/data/7scenes-redkitchen")))
    ap.add_argument("--work", default="/tmp/ef-label-stability")
    ap.add_argument("--model", default=None, help="--model for run and segment (default: the binary's default)")
    ap.add_argument("--every", type=int, default=10, help="labelled frames: every K-th")
    ap.add_argument("--gaps", default="10,50", help="frame distances of the pairs, multiples of --every")
    ap.add_argument("--resolution", default="320x240")
    ap.add_argument("--reuse", action="store_true", help="keep run/segment outputs already in --work")
    ap.add_argument("--json", default=None)
    a = ap.parse_args()

    data = os.path.abspath(a.data)
    run_dir = os.path.join(a.work, "run")
    seg_dir = os.path.join(a.work, "segment")
    os.makedirs(a.work, exist_ok=True)
    model = ["--model", os.path.abspath(a.model)] if a.model else []
    times = {}
    if not (a.reuse and os.path.exists(os.path.join(run_dir, "trajectory.txt"))):
        times["run_s"] = run([a.edgefusion, "run", "--source", "7scenes:" + data, "--out", run_dir,
                              "--labels-out", os.path.join(run_dir, "labels"), "--labels-out-every", str(a.every),
                              "--resolution", a.resolution, "--deterministic", "--overwrite", "--quiet"] + model,
                             os.path.join(a.work, "run.log"))
    if not (a.reuse and os.path.isdir(os.path.join(seg_dir, "labels"))):
        times["segment_s"] = run([a.edgefusion, "segment", "--source", "7scenes:" + data, "--out", seg_dir,
                                  "--every", str(a.every), "--quiet"] + model, os.path.join(a.work, "segment.log"))

    stems = frame_stems(data)
    W, H = (int(t) for t in a.resolution.split("x"))
    src = cv2.imread(os.path.join(data, stems[0] + ".depth.png"), cv2.IMREAD_UNCHANGED)
    step = src.shape[1] // W
    assert src.shape[1] == W * step and src.shape[0] == H * step, "label resolution must divide the source's"
    s = 1.0 / step
    fx, fy, cx, cy = read_intrinsics(data)
    off = ((step // 2) + 0.5) * s - 0.5  # the depth sample's position inside its label pixel
    K = (fx * s, fy * s, (cx + 0.5) * s - 0.5, (cy + 0.5) * s - 0.5, off)

    stamps, est, lost = read_tum_trajectory(os.path.join(run_dir, "trajectory.txt"))
    if len(est) != len(stems):
        sys.exit("trajectory has %d poses for %d frames" % (len(est), len(stems)))
    stamp_err = float(np.max(np.abs(stamps - np.arange(len(stems)) / 30.0)))
    ref = [np.loadtxt(os.path.join(data, st + ".pose.txt")) for st in stems]

    labelled = list(range(0, len(stems), a.every))
    depth, labs = {}, {}
    for i in labelled:
        depth[i] = load_depth_m(os.path.join(data, stems[i] + ".depth.png"), step)
        labs[i] = {"cnn": load_labels(os.path.join(seg_dir, "labels", stems[i] + ".png"), (H, W), step),
                   "fused": load_labels(os.path.join(run_dir, "labels", stems[i] + ".png"), (H, W), step)}

    # Pose check: the run's relative motion between labelled frames against the reference's.
    rel_t, rel_r = [], []
    for i, j in zip(labelled[:-1], labelled[1:]):
        A = np.linalg.inv(est[j]) @ est[i]
        B = np.linalg.inv(ref[j]) @ ref[i]
        D = np.linalg.inv(B) @ A
        rel_t.append(np.linalg.norm(D[:3, 3]))
        rel_r.append(np.degrees(np.arccos(np.clip((np.trace(D[:3, :3]) - 1) / 2, -1, 1))))

    names = ["cnn", "fused"]
    result = {
        "data": data, "frames": len(stems), "labelled_every": a.every, "label_resolution": a.resolution,
        "tolerance_m": TOLERANCE_M, "edgefusion": a.edgefusion, "model": a.model or "(binary's default)",
        "times_s": times,
        "trajectory_check": {"poses": len(est), "lost_frames": sorted(lost),
                             "max_timestamp_minus_index_over_30_s": stamp_err,
                             "relative_pose_vs_reference_per_10_frames": {
                                 "translation_mm_median": 1000 * float(np.median(rel_t)),
                                 "translation_mm_max": 1000 * float(np.max(rel_t)),
                                 "rotation_deg_median": float(np.median(rel_r)),
                                 "rotation_deg_max": float(np.max(rel_r))}},
        "results": {},
    }
    for gap in [int(g) for g in a.gaps.split(",")]:
        for pname, poses in (("estimated", est), ("reference", ref)):
            pairs = []
            for i in labelled:
                j = i + gap
                if j >= len(stems) or j not in depth or i in lost or j in lost:
                    continue
                p = pair_stats(depth[i], depth[j], poses[i], poses[j], K, labs[i], labs[j])
                p["frames"] = [i, j]
                pairs.append(p)
            summ = summarise(pairs, names)
            summ["per_pair_changed_share"] = {
                n: [round(p[n]["changed"] / p[n]["known"], 5) if p[n]["known"] else None for p in pairs]
                for n in names}
            summ["per_pair_covisible_share_of_valid_depth"] = float(
                np.mean([p["covisible"] / max(p["valid_depth"], 1) for p in pairs]))
            result["results"]["gap%d_%s_poses" % (gap, pname)] = summ

    out = a.json or os.path.join(a.work, "label_stability.json")
    with open(out, "w") as f:
        json.dump(result, f, indent=1)

    tc = result["trajectory_check"]
    print("7-Scenes %s: %d frames, labels every %d at %s, co-visible = |dz| < %.0f cm" %
          (data, len(stems), a.every, a.resolution, 100 * TOLERANCE_M))
    print("trajectory: %d poses, %d lost, timestamps = index/30 within %.1e s; vs reference over 10 frames: "
          "median %.1f mm / %.2f deg, max %.1f mm / %.2f deg" %
          (tc["poses"], len(tc["lost_frames"]), stamp_err,
           tc["relative_pose_vs_reference_per_10_frames"]["translation_mm_median"],
           tc["relative_pose_vs_reference_per_10_frames"]["rotation_deg_median"],
           tc["relative_pose_vs_reference_per_10_frames"]["translation_mm_max"],
           tc["relative_pose_vs_reference_per_10_frames"]["rotation_deg_max"]))
    if times:
        print("times: " + ", ".join("%s %.1f" % kv for kv in times.items()))
    print("changed = share of co-visible points (known in both views) whose label differs: mean over pairs / "
          "pooled; int = pooled over points > 2 px from a label boundary in both views")
    print("%-22s %5s %10s | %-36s | %-36s" % ("pairs / poses", "pairs", "covisible",
                                             "CNN: changed mean / pooled / int", "fused: changed mean / pooled / int"))
    for key, r in result["results"].items():
        cells = []
        for n in names:
            cells.append("%5.1f%% / %5.1f%% / %5.1f%% (unk %.2f%%)" % (
                100 * r[n]["changed_share_mean_over_pairs"], 100 * r[n]["changed_share_pooled"],
                100 * r[n]["interior_changed_share_pooled"],
                100 * r[n]["points_unknown_in_either"] / max(r["covisible_points"], 1)))
        print("%-22s %5d %10d | %-36s | %-36s" % (key, r["pairs"], r["covisible_points"], cells[0], cells[1]))
    print("json: " + out)


if __name__ == "__main__":
    main()
