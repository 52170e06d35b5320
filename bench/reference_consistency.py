#!/usr/bin/python3
"""How well two trajectories of a 7-Scenes sequence agree with its depth images, frame to frame: for
each pair of frames (i, i + step), the depth of frame i + step is moved into frame i by the
trajectory's relative pose and associated projectively with frame i's depth (160x120, within
10 cm); the pair's figure is the median point-to-plane distance (metres) to frame i's surface. A
trajectory whose relative motion is right leaves only the sensor's noise. Used to judge the
dataset's reference poses (KinectFusion-made, not motion capture) against ours where the two
disagree (issue 30: what limits the ATE).

    /usr/bin/python3 bench/reference_consistency.py GT.txt EST.txt [--data DIR] [--step 1] [--worst 8]

GT.txt: `edgefusion convert --source 7scenes:DIR --to tum:OUT` writes OUT/groundtruth.txt; EST.txt:
a run's trajectory.txt (one line per frame, in order). Prints the median and mean over all pairs for
each trajectory and the pairs where they differ most.
"""
import argparse
import os

import cv2
import numpy as np

W, H = 160, 120
F = 585.0 * W / 640.0  # 7-Scenes: fx = fy = 585 at 640x480, principal point at the centre


def load_tum(path):
    """4x4 camera-to-world poses, in file order (comment lines skipped)."""
    poses = []
    for line in open(path):
        if line.startswith("#") or not line.strip():
            continue
        v = [float(a) for a in line.split()]
        qx, qy, qz, qw = v[4:8]
        R = np.array([[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
                      [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
                      [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]])
        T = np.eye(4)
        T[:3, :3] = R
        T[:3, 3] = v[1:4]
        poses.append(T)
    return poses


def depth(data, i):
    d = cv2.imread(os.path.join(data, f"frame-{i:06d}.depth.png"), cv2.IMREAD_UNCHANGED).astype(np.float32) / 1000.0
    d[(d <= 0) | (d > 60)] = 0  # 0 and 65535 mean no depth
    return cv2.resize(d, (W, H), interpolation=cv2.INTER_NEAREST)


U, V = np.meshgrid(np.arange(W), np.arange(H))
CX, CY = (W - 1) / 2.0, (H - 1) / 2.0


def vertices(d):
    return np.stack([(U - CX) / F * d, (V - CY) / F * d, d], -1)


def normals(v):
    dx, dy = np.zeros_like(v), np.zeros_like(v)
    dx[:, 1:-1] = v[:, 2:] - v[:, :-2]
    dy[1:-1] = v[2:] - v[:-2]
    n = np.cross(dy, dx)
    return n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-9)


def pair_residual(di, dj, T_ij):
    """Median point-to-plane distance of frame j's points, moved into frame i, to frame i's surface."""
    vi, ni = vertices(di), normals(vertices(di))
    p = vertices(dj)[dj > 0] @ T_ij[:3, :3].T + T_ij[:3, 3]
    p = p[p[:, 2] > 0.1]
    u = np.round(p[:, 0] / p[:, 2] * F + CX).astype(int)
    v = np.round(p[:, 1] / p[:, 2] * F + CY).astype(int)
    inside = (u >= 1) & (u < W - 1) & (v >= 1) & (v < H - 1)
    p, u, v = p[inside], u[inside], v[inside]
    q, n = vi[v, u], ni[v, u]
    near = (q[:, 2] > 0) & (np.abs(q[:, 2] - p[:, 2]) < 0.1)
    return float(np.median(np.abs(((p - q) * n).sum(-1))[near]))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("gt")
    ap.add_argument("est")
    ap.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "../../shared/data/7scenes-redkitchen"))
    ap.add_argument("--step", type=int, default=1)
    ap.add_argument("--worst", type=int, default=8, help="list this many pairs where the two differ most")
    a = ap.parse_args()
    traj = {"reference": load_tum(a.gt), "ours": load_tum(a.est)}
    n = min(len(t) for t in traj.values())
    res = {k: [] for k in traj}
    pairs = list(range(0, n - a.step))
    for i in pairs:
        di, dj = depth(a.data, i), depth(a.data, i + a.step)
        for k, t in traj.items():
            res[k].append(pair_residual(di, dj, np.linalg.inv(t[i]) @ t[i + a.step]))
    for k, r in res.items():
        r = np.array(r)
        print(f"{k:10s} {len(r)} pairs (step {a.step}): point-to-plane residual median {1e3 * np.median(r):.2f} mm, "
              f"mean {1e3 * r.mean():.2f} mm, 95th percentile {1e3 * np.percentile(r, 95):.2f} mm")
    diff = np.array(res["reference"]) - np.array(res["ours"])
    print("pairs where the reference's relative pose fits the depth worst against ours (frame i, i+step):")
    for k in np.argsort(-diff)[:a.worst]:
        step_ref = np.linalg.norm((np.linalg.inv(traj['reference'][pairs[k]]) @ traj['reference'][pairs[k] + a.step])[:3, 3])
        step_our = np.linalg.norm((np.linalg.inv(traj['ours'][pairs[k]]) @ traj['ours'][pairs[k] + a.step])[:3, 3])
        print(f"  {pairs[k]:4d}: reference {1e3 * res['reference'][k]:.2f} mm (moves {100 * step_ref:.2f} cm), "
              f"ours {1e3 * res['ours'][k]:.2f} mm (moves {100 * step_our:.2f} cm)")


if __name__ == "__main__":
    main()
