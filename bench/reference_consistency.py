#!/usr/bin/python3
"""How well trajectories of a 7-Scenes sequence agree with its depth images (issue 30: what limits the
ATE against the dataset's reference, which KinectFusion made from the same depth, not motion capture).

Frame to frame (the default): for each pair of frames (i, i + step), the depth of frame i + step is
moved into frame i by the trajectory's relative pose and associated projectively with frame i's depth
(160x120, within 10 cm); the pair's figure is the median point-to-plane distance (metres) to frame i's
surface. A trajectory whose relative motion is right leaves only the sensor's noise.

Far apart (--far GAP): drift, which is what an ATE over a whole recording measures, shows between
frames that the camera sees again long after. Every --every'th frame is paired with the later ones at
least GAP frames on that every trajectory puts within 0.4 m and 25 degrees of it (the same surface in
view). Each pair is registered directly, depth to depth: point-to-plane ICP at 320x240, Huber-weighted,
started from each trajectory's relative pose in turn; a pair counts when every start ends within 2 mm
and 0.1 degree of the others (one well-determined answer) on at least 2000 associations. Each
trajectory's relative pose is then compared with that registration: the translation (mm) and rotation
(degrees) of the difference, median and 90th percentile over the pairs, and the residual at the
trajectory's own relative pose before registering. This registration uses no trajectory beyond its
start and no map: it is a measurement of the pair's relative pose from the depth alone.

    /usr/bin/python3 bench/reference_consistency.py GT.txt EST.txt [--with NAME=TUM ...]
        [--data DIR] [--step 1] [--worst 8] [--far GAP] [--every 10]

GT.txt: `edgefusion convert --source 7scenes:DIR --to tum:OUT` writes OUT/groundtruth.txt; EST.txt:
a run's trajectory.txt (one line per frame, in order); --with adds more trajectories (for instance the
SfM pseudo ground truth that bench/second_reference.py --write-tum writes). Frame to frame it prints
the median and mean over all pairs for each trajectory and the pairs where the reference and EST
differ most.
"""
import argparse
import os

import cv2
import numpy as np

FX_640 = 585.0  # 7-Scenes: fx = fy = 585 at 640x480, principal point at the centre


class Camera:
    """A pinhole at W x H with 7-Scenes' intrinsics scaled, and its pixel grid."""

    def __init__(self, w, h):
        self.w, self.h = w, h
        self.f = FX_640 * w / 640.0
        self.cx, self.cy = (w - 1) / 2.0, (h - 1) / 2.0
        self.u, self.v = np.meshgrid(np.arange(w), np.arange(h))

    def vertices(self, d):
        return np.stack([(self.u - self.cx) / self.f * d, (self.v - self.cy) / self.f * d, d], -1)

    def project(self, p):
        """Pixel (u, v) of each point, rounded, and whether it lands in the image in front of the camera."""
        z = np.where(p[:, 2] > 0.1, p[:, 2], 1.0)
        u = np.round(p[:, 0] / z * self.f + self.cx).astype(int)
        v = np.round(p[:, 1] / z * self.f + self.cy).astype(int)
        return u, v, (p[:, 2] > 0.1) & (u >= 1) & (u < self.w - 1) & (v >= 1) & (v < self.h - 1)


def orthonormal(R):
    U, _, Vt = np.linalg.svd(R)
    return U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt


def quat_to_R(w, x, y, z):
    """Rotation matrix of a quaternion (normalised first)."""
    n = np.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def load_tum(path):
    """4x4 camera-to-world poses, in file order (comment lines skipped)."""
    with open(path) as f:
        lines = f.read().splitlines()
    poses = []
    for line in lines:
        if line.startswith("#") or not line.strip():
            continue
        v = [float(a) for a in line.split()]
        T = np.eye(4)
        T[:3, :3] = orthonormal(quat_to_R(v[7], v[4], v[5], v[6]))  # unit only to the printed digits
        T[:3, 3] = v[1:4]
        poses.append(T)
    return poses


def depth(data, i, cam):
    d = cv2.imread(os.path.join(data, f"frame-{i:06d}.depth.png"), cv2.IMREAD_UNCHANGED).astype(np.float32) / 1000.0
    d[(d <= 0) | (d > 60)] = 0  # 0 and 65535 mean no depth
    return cv2.resize(d, (cam.w, cam.h), interpolation=cv2.INTER_NEAREST)


def surface(d, cam):
    """Vertices, unit normals (central differences) and where both are valid."""
    v = cam.vertices(d)
    dx, dy = np.zeros_like(v), np.zeros_like(v)
    dx[:, 1:-1] = v[:, 2:] - v[:, :-2]
    dy[1:-1] = v[2:] - v[:-2]
    n = np.cross(dy, dx)
    length = np.linalg.norm(n, axis=-1)
    ok = (d > 0) & (length > 0)
    ok[:, 1:-1] &= (d[:, 2:] > 0) & (d[:, :-2] > 0)
    ok[1:-1] &= (d[2:] > 0) & (d[:-2] > 0)
    ok[:, [0, -1]] = False
    ok[[0, -1]] = False
    return v, n / np.maximum(length, 1e-12)[..., None], ok


def associate(surf_i, p, cam, within):
    """Frame j's points p (in frame i) paired with frame i's vertex at their pixel, within `within` m."""
    vi, ni, oki = surf_i
    u, v, inside = cam.project(p)
    keep = np.where(inside)[0]
    keep = keep[oki[v[keep], u[keep]]]
    q, n = vi[v[keep], u[keep]], ni[v[keep], u[keep]]
    p = p[keep]
    near = np.linalg.norm(p - q, axis=1) < within
    return p[near], q[near], n[near]


def pair_residual(di, dj, T_ij, cam):
    """Median point-to-plane distance of frame j's points, moved into frame i, to frame i's surface
    (projective association within 10 cm along the ray)."""
    vi, ni, _ = surface(di, cam)
    p = cam.vertices(dj)[dj > 0] @ T_ij[:3, :3].T + T_ij[:3, 3]
    u, v, inside = cam.project(p)
    p, u, v = p[inside], u[inside], v[inside]
    q, n = vi[v, u], ni[v, u]
    near = (q[:, 2] > 0) & (np.abs(q[:, 2] - p[:, 2]) < 0.1)
    return float(np.median(np.abs(((p - q) * n).sum(-1))[near]))


def se3_exp(x):
    """4x4 transform of a twist (rotation vector, translation), the translation taken as is (small steps)."""
    w = x[:3]
    th = np.linalg.norm(w)
    K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    T = np.eye(4)
    T[:3, :3] = np.eye(3) + K if th < 1e-12 else np.eye(3) + np.sin(th) / th * K + (1 - np.cos(th)) / th ** 2 * K @ K
    T[:3, 3] = x[3:]
    return T


def register(di, dj, T, cam, steps=30):
    """Point-to-plane ICP of frame j's depth onto frame i's from the start T (j into i). The association
    radius shrinks 10 -> 5 -> 2 cm over the steps; Huber weights at 1.5 robust sigmas. Returns the
    transform and the number of associations at 2 cm."""
    surf_i = surface(di, cam)
    pj = cam.vertices(dj)[dj > 0]
    radii = (0.10, 0.05, 0.02)
    for k in range(steps):
        p = pj @ T[:3, :3].T + T[:3, 3]
        p, q, n = associate(surf_i, p, cam, radii[k * len(radii) // steps])
        r = ((p - q) * n).sum(1)
        sigma = 1.4826 * np.median(np.abs(r)) + 1e-6
        w = np.minimum(1.0, 1.5 * sigma / np.maximum(np.abs(r), 1e-12))
        J = np.hstack([np.cross(p, n), n])
        x = np.linalg.solve((J * w[:, None]).T @ J, -(J * w[:, None]).T @ r)
        T = se3_exp(x) @ T
        if np.linalg.norm(x) < 1e-7 and radii[k * len(radii) // steps] == radii[-1]:
            break
    p = pj @ T[:3, :3].T + T[:3, 3]
    return T, len(associate(surf_i, p, cam, radii[-1])[0])


def angle_deg(R):
    return float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0))))


def frame_to_frame(a, traj):
    cam = Camera(160, 120)
    n = min(len(t) for t in traj.values())
    res = {k: [] for k in traj}
    pairs = list(range(0, n - a.step))
    for i in pairs:
        di, dj = depth(a.data, i, cam), depth(a.data, i + a.step, cam)
        for k, t in traj.items():
            res[k].append(pair_residual(di, dj, np.linalg.inv(t[i]) @ t[i + a.step], cam))
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


def far_apart(a, traj):
    cam = Camera(320, 240)
    n = min(len(t) for t in traj.values())
    cos_limit = np.cos(np.radians(25.0))
    pairs = [(i, j) for i in range(0, n, a.every) for j in range(i + a.far, n, a.every)
             if all(np.linalg.norm(t[i][:3, 3] - t[j][:3, 3]) <= 0.4 and t[i][:3, 2] @ t[j][:3, 2] >= cos_limit
                    for t in traj.values())]
    cache = {}

    def dep(i):
        if i not in cache:
            cache[i] = depth(a.data, i, cam)
        return cache[i]

    err = {k: [] for k in traj}
    used = []
    for i, j in pairs:
        starts = {k: np.linalg.inv(t[i]) @ t[j] for k, t in traj.items()}
        ends = [register(dep(i), dep(j), T0, cam) for T0 in starts.values()]
        first = ends[0][0]
        agree = all(np.linalg.norm(T[:3, 3] - first[:3, 3]) <= 0.002 and angle_deg(first[:3, :3].T @ T[:3, :3]) <= 0.1
                    for T, _ in ends)
        if not agree or min(c for _, c in ends) < 2000:
            continue
        measured = sum(T for T, _ in ends) / len(ends)
        measured[:3, :3] = orthonormal(measured[:3, :3])
        used.append((i, j))
        for k, T0 in starts.items():
            d = np.linalg.inv(measured) @ T0
            err[k].append((np.linalg.norm(d[:3, 3]), angle_deg(d[:3, :3]), pair_residual(dep(i), dep(j), T0, cam)))
    gaps = [j - i for i, j in used]
    print(f"{len(pairs)} pairs at least {a.far} frames apart with the same view in every trajectory (every "
          f"{a.every}th frame); {len(used)} registered to one answer from every start (gaps {min(gaps, default=0)}-"
          f"{max(gaps, default=0)} frames)")
    if not used:
        return
    print("| trajectory | translation error, median mm | p90 mm | rotation error, median deg | p90 deg | "
          "residual before registering, median mm | pairs where it is the closest |")
    print("|---|---|---|---|---|---|---|")
    e = {k: np.array(v) for k, v in err.items()}
    closest = np.argmin(np.stack([v[:, 0] for v in e.values()]), axis=0)
    for m, (k, v) in enumerate(e.items()):
        print(f"| {k} | {1e3 * np.median(v[:, 0]):.1f} | {1e3 * np.percentile(v[:, 0], 90):.1f} | "
              f"{np.median(v[:, 1]):.2f} | {np.percentile(v[:, 1], 90):.2f} | {1e3 * np.median(v[:, 2]):.2f} | "
              f"{100 * np.mean(closest == m):.0f}% |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("gt")
    ap.add_argument("est")
    ap.add_argument("--with", dest="more", action="append", default=[], metavar="NAME=TUM",
                    help="another trajectory to compare (repeatable)")
    ap.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "../../shared/data/7scenes-redkitchen"))
    ap.add_argument("--step", type=int, default=1)
    ap.add_argument("--worst", type=int, default=8, help="list this many pairs where the two differ most")
    ap.add_argument("--far", type=int, default=0, metavar="GAP",
                    help="instead: register pairs at least GAP frames apart directly and compare")
    ap.add_argument("--every", type=int, default=10, help="with --far: every N'th frame is paired")
    a = ap.parse_args()
    traj = {"reference": load_tum(a.gt), "ours": load_tum(a.est)}
    for spec in a.more:
        name, _, path = spec.partition("=")
        if not path:
            ap.error(f"--with '{spec}': expected NAME=FILE")
        traj[name] = load_tum(path)
    if a.far > 0:
        far_apart(a, traj)
    else:
        frame_to_frame(a, traj)


if __name__ == "__main__":
    main()
