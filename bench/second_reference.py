#!/usr/bin/python3
"""The 7-Scenes kitchen against a second, independent reference (issue 30: what the 2.0 cm goal runs
into). The dataset's reference poses were made by KinectFusion from the same depth images our tracker
reads; Brachmann et al. ("On the Limits of Pseudo Ground Truth in Visual Camera Re-localisation",
ICCV 2021) rebuilt every 7-Scenes sequence by structure from motion (COLMAP, colour images only) and
published both in one format: github.com/tsattler/visloc_pseudo_gt_limitations, folder pgt/ (research
use like 7-Scenes itself: read it from a checkout, never copy it into this repository).

With three trajectories of one camera whose errors are independent, the mean squared differences of
the three pairs give each one's own error (the "three-cornered hat" of clock comparisons):
    e_A^2 = (d_AB^2 + d_AC^2 - d_BC^2) / 2,
where d_XY is the ATE RMSE of X against Y (each pair aligned on its own). Used here to estimate how
far the KinectFusion reference itself is from the truth, which bounds what an ATE measured against it
can show. Errors of ours and of the reference that are correlated (both track the same depth images)
make e_ref^2 smaller by the covariance: the estimate is then a lower bound. A 95% interval comes from
a block bootstrap over the frames (blocks of 50 consecutive frames, each resample re-aligned; rough,
see BLOCK).

    /usr/bin/python3 bench/second_reference.py --pgt DIR EST.txt [EST2.txt ...]
        [--data DIR] [--sequence seq-01] [--write-tum OUT.txt]

DIR: a checkout of the repository above. EST.txt: a run's trajectory.txt (TUM, one line per frame in
order). The frames in ../shared are sequence seq-01's first 1000; the script checks that the pGT
file's D-SLAM poses are the dataset's own (after the depth-to-colour transform it derives from them,
printed) and stops otherwise. --write-tum writes the SfM poses, moved to the depth camera, as a TUM
trajectory (for `edgefusion eval ate` or bench/reference_consistency.py --with).
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import reference_consistency as rc  # noqa: E402  (poses: quaternions, TUM files)
from reference_consistency import orthonormal as nearest_rotation, quat_to_R  # noqa: E402

# Frames per bootstrap block (1.7 s at 30 Hz). Trajectory errors vary more slowly than that, and the
# interval moves with the block length (25-200 frames: its lower end for the reference 0.7-1.6 cm on
# the kitchen): read it as rough.
BLOCK = 50
RESAMPLES = 1000  # bootstrap resamples


def load_pgt(path, sequence):
    """{frame index: (R camera-to-world, camera centre)} of one sequence of a pGT file (COLMAP's
    convention: p_cam = R(q) p_world + t, one 'seq-NN/frame-NNNNNN.color.png qw qx qy qz tx ty tz f'
    line per image)."""
    out = {}
    with open(path) as f:
        lines = f.read().splitlines()
    for line in lines:
        fields = line.split()
        if len(fields) < 8 or not fields[0].startswith(sequence + "/frame-"):
            continue
        i = int(fields[0].split("frame-")[1].split(".")[0])
        Rw = quat_to_R(*map(float, fields[1:5]))
        t = np.array([float(v) for v in fields[5:8]])
        out[i] = (Rw.T, -Rw.T @ t)
    return out


def load_dataset(data, n):
    """The dataset's own reference: frame-NNNNNN.pose.txt, 4x4 camera-to-world (rotations made exactly
    orthonormal: the files carry about 4e-4 of scale)."""
    R, C = [], []
    for i in range(n):
        M = np.loadtxt(os.path.join(data, f"frame-{i:06d}.pose.txt"))
        R.append(nearest_rotation(M[:3, :3]))
        C.append(M[:3, 3])
    return np.array(R), np.array(C)


def load_tum(path):
    """(rotations, centres) of a TUM trajectory, in file order."""
    poses = np.array(rc.load_tum(path))
    return poses[:, :3, :3], poses[:, :3, 3]


def align(P, Q, with_scale=False):
    """Umeyama: s, R, t minimising |s R P + t - Q|^2 over the rows."""
    mp, mq = P.mean(0), Q.mean(0)
    X, Y = P - mp, Q - mq
    U, S, Vt = np.linalg.svd(Y.T @ X / len(P))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U) * np.linalg.det(Vt)) or 1.0])
    R = U @ D @ Vt
    s = float((S * np.diag(D)).sum() / X.var(0).sum()) if with_scale else 1.0
    return s, R, mq - s * R @ mp


def ate_rmse(P, Q, with_scale=False):
    s, R, t = align(P, Q, with_scale)
    return float(np.sqrt((((s * P @ R.T + t) - Q) ** 2).sum(1).mean())), s


def hat(d_ab, d_ac, d_bc):
    """Each trajectory's own mean squared error from the three pairs' (A, B, C order)."""
    return ((d_ab + d_ac - d_bc) / 2, (d_ab + d_bc - d_ac) / 2, (d_ac + d_bc - d_ab) / 2)


def signed_sqrt_cm(v):
    return float(np.sign(v) * np.sqrt(abs(v)) * 100)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("est", nargs="+", help="trajectory.txt of a run (TUM)")
    ap.add_argument("--pgt", required=True, help="checkout of tsattler/visloc_pseudo_gt_limitations")
    ap.add_argument("--data", default=os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                   "../../shared/data/7scenes-redkitchen"))
    ap.add_argument("--scene", default="redkitchen")
    ap.add_argument("--split", default="train", help="seq-01 is in the training split")
    ap.add_argument("--sequence", default="seq-01")
    ap.add_argument("--write-tum", help="write the SfM poses, in the depth camera, as a TUM trajectory")
    a = ap.parse_args()

    files = {k: os.path.join(a.pgt, "pgt", k, "7scenes", f"{a.scene}_{a.split}.txt") for k in ("sfm", "dslam")}
    for k, f in files.items():
        if not os.path.isfile(f):
            sys.exit(f"second_reference: no {k} pGT file '{f}' (--pgt: a checkout of "
                     "github.com/tsattler/visloc_pseudo_gt_limitations)")
    if not os.path.isfile(os.path.join(a.data, "frame-000000.pose.txt")):
        sys.exit(f"second_reference: no 7-Scenes frames in '{a.data}' (--data)")
    sfm, dslam = load_pgt(files["sfm"], a.sequence), load_pgt(files["dslam"], a.sequence)
    ests = {os.path.basename(os.path.dirname(os.path.abspath(p))) or p: load_tum(p) for p in a.est}
    n = min([len(e[1]) for e in ests.values()] + [len(sfm), len(dslam)])
    if any(i not in sfm or i not in dslam for i in range(n)):
        sys.exit(f"second_reference: {a.sequence} lacks frames 0..{n - 1} in the pGT files")
    ref = load_dataset(a.data, n)

    # The pGT files hold colour-camera poses; the dataset's are the depth camera's. The D-SLAM file is
    # the dataset's poses moved by one fixed depth-to-colour transform: derive it (rotation Rx, centre
    # offset bx in the depth camera's frame) and check that it explains every frame.
    dR = np.array([dslam[i][0] for i in range(n)])
    dC = np.array([dslam[i][1] for i in range(n)])
    Rx = nearest_rotation(np.einsum("nji,njk->ik", ref[0], dR) / n)
    bx = np.einsum("nji,nj->i", ref[0], dC - ref[1]) / n
    miss = np.linalg.norm(ref[1] + ref[0] @ bx - dC, axis=1).max()
    angle = np.degrees(np.arccos(np.clip((np.trace(Rx) - 1) / 2, -1, 1)))
    print(f"depth-to-colour transform from the D-SLAM file: offset {np.round(100 * bx, 2)} cm, rotation "
          f"{angle:.2f} deg; the dataset's poses moved by it meet the file's within {1000 * miss:.2f} mm")
    if miss > 0.002:
        sys.exit("second_reference: the pGT file's D-SLAM poses are not this dataset's frames "
                 f"(--sequence {a.sequence}?)")
    sR = np.array([sfm[i][0] for i in range(n)]) @ Rx.T          # SfM, moved to the depth camera
    sC = np.array([sfm[i][1] for i in range(n)]) - np.einsum("nij,j->ni", sR, bx)
    if a.write_tum:
        with open(a.write_tum, "w") as f:
            f.write(f"# SfM pseudo ground truth (Brachmann et al. 2021), {a.scene} {a.sequence}, "
                    "moved to the depth camera\n# timestamp tx ty tz qx qy qz qw\n")
            for i in range(n):
                R = sR[i]
                w = np.sqrt(max(1e-12, 1 + np.trace(R))) / 2
                x, y, z = (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w)
                f.write(f"{i / 30:.6f} {sC[i][0]:.6f} {sC[i][1]:.6f} {sC[i][2]:.6f} {x:.8f} {y:.8f} {z:.8f} {w:.8f}\n")
        print(f"wrote {a.write_tum}")

    centres = {"reference": ref[1], "sfm": sC}
    centres.update({k: e[1][:n] for k, e in ests.items()})
    names = list(centres)
    print(f"\n{n} frames; ATE RMSE of each pair, cm (rigid; with a scale in brackets, and the scale)")
    print("| pair | ATE cm | with scale |\n|---|---|---|")
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            r, _ = ate_rmse(centres[names[i]], centres[names[j]])
            rs, s = ate_rmse(centres[names[i]], centres[names[j]], True)
            print(f"| {names[i]} / {names[j]} | {100 * r:.2f} | {100 * rs:.2f} (x{s:.4f}) |")

    rng = np.random.default_rng(1)
    blocks = (n + BLOCK - 1) // BLOCK
    print("\nthree-cornered hat (reference, sfm, one of ours): each one's own error, cm RMS (95% interval, "
          "block bootstrap; a negative value is a negative mean square: within the method's noise)")
    print("| ours | reference's own | SfM's own | ours' own |\n|---|---|---|---|")
    for k in names[2:]:
        A, B, C = centres["reference"], centres["sfm"], centres[k]

        def estimate(idx):
            return hat(ate_rmse(A[idx], B[idx])[0] ** 2, ate_rmse(A[idx], C[idx])[0] ** 2,
                       ate_rmse(B[idx], C[idx])[0] ** 2)

        full = estimate(np.arange(n))
        boot = []
        for _ in range(RESAMPLES):
            pick = rng.integers(0, blocks, blocks)
            idx = np.concatenate([np.arange(b * BLOCK, min(n, (b + 1) * BLOCK)) for b in pick])
            boot.append(estimate(idx))
        lo, hi = np.percentile(np.array(boot), [2.5, 97.5], axis=0)
        cells = [f"{signed_sqrt_cm(full[m]):.2f} ({signed_sqrt_cm(lo[m]):.2f} to {signed_sqrt_cm(hi[m]):.2f})"
                 for m in range(3)]
        print(f"| {k} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
