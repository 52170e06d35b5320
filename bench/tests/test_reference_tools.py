"""The measuring tools of issue 30's reference analysis (bench/reference_consistency.py and
bench/second_reference.py) on inputs whose answer is known: a depth pair of a rendered room corner
with a known relative pose, three trajectories with known independent errors, and a pGT file made from
known poses and a known depth-to-colour transform."""
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np

BENCH = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, BENCH)
import reference_consistency as rc  # noqa: E402
import second_reference as sr  # noqa: E402


def rotation(axis, deg):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    return rc.se3_exp(np.r_[a * np.radians(deg), 0, 0, 0])[:3, :3]


def pose(R, t):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


def render_corner(cam, T_wc):
    """Depth (metres) of three planes meeting at the world origin (x = 0, y = 0, z = 0: two walls and a
    floor), seen by a camera at camera-to-world T_wc: the nearest positive ray hit per pixel."""
    rays = np.stack([(cam.u - cam.cx) / cam.f, (cam.v - cam.cy) / cam.f, np.ones_like(cam.u, float)], -1)
    d_world = rays @ T_wc[:3, :3].T
    o = T_wc[:3, 3]
    depth = np.full(cam.u.shape, np.inf)
    for axis in range(3):
        with np.errstate(divide="ignore", invalid="ignore"):
            z = -o[axis] / d_world[..., axis]  # ray parameter = camera depth (rays have z = 1)
        hit = o + z[..., None] * d_world
        others = [k for k in range(3) if k != axis]
        ok = (z > 0.1) & np.all(np.stack([hit[..., k] >= 0 for k in others]), 0) & np.all(
            np.stack([hit[..., k] <= 3.0 for k in others]), 0)
        depth = np.where(ok & (z < depth), z, depth)
    return np.where(np.isfinite(depth), depth, 0).astype(np.float32)


class RegisterTest(unittest.TestCase):
    def test_recovers_a_known_relative_pose_from_a_wrong_start(self):
        cam = rc.Camera(320, 240)
        # Look at the corner from inside the room (the camera's z axis towards the origin).
        def look_at(eye):
            z = -np.asarray(eye, float) / np.linalg.norm(eye)
            x = np.cross(z, [0, 0, 1.0])
            x /= np.linalg.norm(x)
            return pose(np.stack([x, np.cross(z, x), z], 1), eye)
        Ti, Tj = look_at([1.6, 1.4, 1.2]), look_at([1.5, 1.7, 1.0])
        di, dj = render_corner(cam, Ti), render_corner(cam, Tj)
        self.assertGreater((di > 0).mean(), 0.9)
        truth = np.linalg.inv(Ti) @ Tj
        start = pose(rotation([1, 2, 3], 1.5), [0.03, -0.02, 0.02]) @ truth  # 4 cm and 1.5 degrees off
        T, count = rc.register(di, dj, start, cam)
        d = np.linalg.inv(truth) @ T
        self.assertGreater(count, 2000)
        self.assertLess(np.linalg.norm(d[:3, 3]), 1e-3)  # within 1 mm
        self.assertLess(rc.angle_deg(d[:3, :3]), 0.05)
        # and the residual at the true pose is nothing but the rendering's quantisation
        self.assertLess(rc.pair_residual(di, dj, truth, cam), 1e-3)
        self.assertGreater(rc.pair_residual(di, dj, start, cam), 5e-3)


class HatTest(unittest.TestCase):
    def test_three_independent_errors_are_recovered(self):
        rng = np.random.default_rng(7)
        n = 20000
        truth = np.cumsum(rng.normal(0, 0.01, (n, 3)), 0)
        sd = {"a": 0.01, "b": 0.02, "c": 0.03}
        est = {k: truth + rng.normal(0, s, (n, 3)) for k, s in sd.items()}
        d = {(x, y): sr.ate_rmse(est[x], est[y])[0] ** 2 for x, y in [("a", "b"), ("a", "c"), ("b", "c")]}
        got = sr.hat(d[("a", "b")], d[("a", "c")], d[("b", "c")])
        for (k, s), g in zip(sd.items(), got):
            # each one's own error is its RMS over 3 axes: sqrt(3) s
            self.assertAlmostEqual(np.sqrt(g), np.sqrt(3) * s, delta=0.05 * np.sqrt(3) * s, msg=k)

    def test_alignment_removes_a_rigid_motion_and_a_scale(self):
        rng = np.random.default_rng(3)
        P = rng.normal(0, 1, (100, 3))
        Q = 1.02 * P @ rotation([0, 1, 1], 30).T + [1, 2, 3]
        self.assertAlmostEqual(sr.ate_rmse(P, Q, with_scale=True)[0], 0, places=9)
        self.assertAlmostEqual(sr.ate_rmse(P, Q, with_scale=True)[1], 1.02, places=9)
        self.assertGreater(sr.ate_rmse(P, Q)[0], 0.01)


class SecondReferenceTest(unittest.TestCase):
    def test_the_sfm_poses_reach_the_depth_camera_through_the_derived_transform(self):
        rng = np.random.default_rng(5)
        n = 40
        Rx, bx = rotation([1, -1, 2], 0.7), np.array([0.025, 0.0005, -0.002])
        with tempfile.TemporaryDirectory() as tmp:
            data, pgt = os.path.join(tmp, "data"), os.path.join(tmp, "pgt")
            os.makedirs(data)
            for k in ("sfm", "dslam"):
                os.makedirs(os.path.join(pgt, "pgt", k, "7scenes"))
            depth_cam, lines = [], {"sfm": [], "dslam": []}
            for i in range(n):
                R = rotation(rng.normal(size=3), rng.uniform(0, 60))
                C = rng.normal(0, 1, 3)
                depth_cam.append((R, C))
                np.savetxt(os.path.join(data, f"frame-{i:06d}.pose.txt"), pose(R, C))
                # The colour camera: R Rx at C + R bx. The SfM copy is the same camera 1 cm off along x.
                for k, off in (("dslam", 0.0), ("sfm", 0.01)):
                    Rc, Cc = R @ Rx, C + R @ bx + [off, 0, 0]
                    Rw, tw = Rc.T, -Rc.T @ Cc
                    w = np.sqrt(1 + np.trace(Rw)) / 2
                    q = [w, (Rw[2, 1] - Rw[1, 2]) / (4 * w), (Rw[0, 2] - Rw[2, 0]) / (4 * w), (Rw[1, 0] - Rw[0, 1]) / (4 * w)]
                    lines[k].append(f"seq-01/frame-{i:06d}.color.png " + " ".join(f"{v:.9f}" for v in q + list(tw)) + " 525.0")
            for k in lines:
                with open(os.path.join(pgt, "pgt", k, "7scenes", "redkitchen_train.txt"), "w") as f:
                    f.write("\n".join(lines[k][::-1]) + "\n")  # order in the file does not matter
            est = os.path.join(tmp, "run", "trajectory.txt")
            os.makedirs(os.path.dirname(est))
            with open(est, "w") as f:
                for i, (R, C) in enumerate(depth_cam):
                    Rw = R
                    w = np.sqrt(1 + np.trace(Rw)) / 2
                    x, y, z = (Rw[2, 1] - Rw[1, 2]) / (4 * w), (Rw[0, 2] - Rw[2, 0]) / (4 * w), (Rw[1, 0] - Rw[0, 1]) / (4 * w)
                    f.write(f"{i / 30:.6f} {C[0]:.9f} {C[1]:.9f} {C[2]:.9f} {x:.9f} {y:.9f} {z:.9f} {w:.9f}\n")
            sfm_tum = os.path.join(tmp, "sfm.txt")
            out = subprocess.run([sys.executable, os.path.join(BENCH, "second_reference.py"), "--pgt", pgt, "--data",
                                  data, "--write-tum", sfm_tum, est], capture_output=True, text=True)
            self.assertEqual(out.returncode, 0, out.stderr)
            self.assertIn("offset [ 2.5   0.05 -0.2 ] cm", out.stdout)
            self.assertIn("rotation 0.70 deg", out.stdout)
            # The SfM poses, moved to the depth camera, are the depth camera's poses 1 cm off along x.
            sfm = rc.load_tum(sfm_tum)
            for (R, C), T in zip(depth_cam, sfm):
                self.assertLess(np.linalg.norm(T[:3, 3] - (C + [0.01, 0, 0])), 1e-6)
                self.assertLess(rc.angle_deg(R.T @ T[:3, :3]), 1e-4)
            self.assertIn("| reference / run | 0.00 |", out.stdout)
            self.assertIn("| reference / sfm | 0.00 |", out.stdout)  # a constant offset aligns away

            # A pGT file that is not this dataset's poses is refused, saying so.
            np.savetxt(os.path.join(data, "frame-000003.pose.txt"), pose(np.eye(3), [5, 5, 5]))
            out = subprocess.run([sys.executable, os.path.join(BENCH, "second_reference.py"), "--pgt", pgt, "--data",
                                  data, est], capture_output=True, text=True)
            self.assertNotEqual(out.returncode, 0)
            self.assertIn("not this dataset's frames", out.stderr)


if __name__ == "__main__":
    unittest.main()
