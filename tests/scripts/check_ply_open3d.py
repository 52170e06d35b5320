#!/usr/bin/env python3
"""Reads the PLY written by ply_fixture with Open3D (Debian's python3-open3d), as a user's tool
would, and checks point count, positions, normals and colours against the fixture's formulas.
Also checks the custom per-vertex attributes through Open3D's tensor API.
Exit status 0 = pass; anything else (including a missing open3d module) = fail."""
import sys


def fail(msg):
    print("check_ply_open3d: FAIL: " + msg, file=sys.stderr)
    sys.exit(1)


def main():
    if len(sys.argv) != 2:
        fail("usage: check_ply_open3d.py FILE.ply")
    path = sys.argv[1]
    try:
        import numpy as np
        import open3d as o3d
    except Exception as e:  # the test must fail, not skip, when Open3D is absent
        fail("cannot import open3d/numpy (install with scripts/install-deps.sh test): %r" % (e,))

    n = 7
    i = np.arange(n, dtype=np.float64)
    pos = np.stack([0.25 * i, 1.0 - 0.5 * i, 2.0 + 0.125 * i], axis=1)
    nrm = np.zeros((n, 3))
    nrm[np.arange(n), np.arange(n) % 3] = 1.0
    rgb = np.stack([30 * i, 255 - 20 * i, 7 * i], axis=1)  # 0..255
    radius = 0.5 * (i + 1) / 64.0
    conf = i.copy()
    cls = np.arange(n) % 14
    prob = 0.125 * i

    pcd = o3d.io.read_point_cloud(path)
    got = len(pcd.points)
    if got != n:
        fail("legacy reader: %d points, expected %d" % (got, n))
    if not pcd.has_normals():
        fail("legacy reader: no normals")
    if not pcd.has_colors():
        fail("legacy reader: no colours")
    if not np.allclose(np.asarray(pcd.points), pos, atol=1e-6):
        fail("legacy reader: positions differ:\n%s" % np.asarray(pcd.points))
    if not np.allclose(np.asarray(pcd.normals), nrm, atol=1e-6):
        fail("legacy reader: normals differ:\n%s" % np.asarray(pcd.normals))
    if not np.allclose(np.asarray(pcd.colors) * 255.0, rgb, atol=1e-3):
        fail("legacy reader: colours differ:\n%s" % (np.asarray(pcd.colors) * 255.0))

    tp = o3d.t.io.read_point_cloud(path)
    attrs = tp.point
    def arr(name):
        if name not in attrs:
            fail("tensor reader: no attribute '%s' (has %s)" % (name, sorted(str(k) for k in attrs)))
        return attrs[name].numpy().reshape(n, -1)
    if not np.allclose(arr("positions"), pos, atol=1e-6):
        fail("tensor reader: positions differ")
    if not np.allclose(arr("normals"), nrm, atol=1e-6):
        fail("tensor reader: normals differ")
    colors = arr("colors").astype(np.float64)
    if colors.max() <= 1.0 + 1e-6:  # some versions normalise uint8 colours to [0, 1]
        colors = colors * 255.0
    if not np.allclose(colors, rgb, atol=1e-3):
        fail("tensor reader: colours differ:\n%s" % colors)
    if not np.allclose(arr("radius")[:, 0], radius, atol=1e-7):
        fail("tensor reader: radius differs: %s" % arr("radius")[:, 0])
    if not np.allclose(arr("confidence")[:, 0], conf, atol=1e-7):
        fail("tensor reader: confidence differs")
    if not np.array_equal(arr("class_id")[:, 0].astype(np.int64), cls):
        fail("tensor reader: class_id differs: %s" % arr("class_id")[:, 0])
    if not np.allclose(arr("class_prob")[:, 0], prob, atol=1e-7):
        fail("tensor reader: class_prob differs")
    print("check_ply_open3d: OK: %d points, positions, normals, colours, radius, confidence, class_id, "
          "class_prob match (open3d %s)" % (n, o3d.__version__))


if __name__ == "__main__":
    main()
