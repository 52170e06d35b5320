#!/usr/bin/python3
"""Open3D frame-to-frame RGB-D odometry (hybrid term) on a 7-Scenes sequence: the peer of
EdgeFusion's tracker in bench/slam_vs_open3d.sh.

Usage (Debian 12: apt-get install python3-open3d; run with /usr/bin/python3):
    OMP_NUM_THREADS=1 /usr/bin/python3 bench/open3d_odometry.py --data DIR \
        [--frames N] [--resolution 320x240] [--out trajectory.txt] [--stats stats.json] [--quiet]

What it does, frame by frame, the way EdgeFusion's 7scenes source and resampler prepare a frame:
  * reads frame-NNNNNN.color.jpg (.color.png when there is no jpg) and frame-NNNNNN.depth.png
    (millimetres; 0 and 65535 mean "no depth"), intrinsics from camera-intrinsics.txt
    (fx = fy = 585, cx = 320, cy = 240 when absent), poses from frame-NNNNNN.pose.txt;
  * shrinks to the working resolution by an integer factor f (640x480 -> 320x240: f = 2):
      colour: f x f box average, as OpenCV's INTER_AREA (for f = 2: (a + b + c + d + 2) >> 2);
      depth:  the mean of the valid depths of each f x f block lying within 0.05 m of the block's
              nearest valid depth (src/io/frame_resample.cpp), in float32 like the C++ code;
      intrinsics: fx' = fx / f, cx' = (cx + 0.5) / f - 0.5 (Intrinsics::scaled_to);
  * depth cut-off 8 m (EdgeFusion's PreprocessOptions::depth_cutoff_m) when making the RGBDImage;
  * o3d.pipelines.odometry.compute_rgbd_odometry(current, previous, ...) with
    RGBDOdometryJacobianFromHybridTerm, the default OdometryOption (iterations 20/10/5,
    depth_diff_max 0.03 m, depth 0..4 m) and identity as the initial motion;
  * chains the motions (pose_i = pose_{i-1} * T, T maps frame i's camera into frame i-1's); frame 0
    takes its reference pose (identity when there is none); a failed odometry call keeps the
    previous pose and is counted;
  * writes a TUM trajectory (timestamp = index / 30 s as EdgeFusion's 7scenes source, "%.6f",
    camera to world, tx ty tz qx qy qz qw).
Only the compute_rgbd_odometry call is timed (wall: perf_counter; CPU: process_time, which shows
whether other jobs took the cores); reading, resampling and building the RGBDImage are not.
Printed: frames, odometry ms/frame median / mean / p95 / max, CPU ms median / mean, failures.
--stats writes the same as JSON. Exit 2 when open3d or numpy cannot be imported or the data folder
is missing; 1 on bad data; 0 otherwise.

OMP_NUM_THREADS is set to 1 here when the caller did not set it (Open3D's odometry uses OpenMP).
"""

import argparse
import json
import math
import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

FRAME_RATE_HZ = 30.0          # sevenscenes_source.cpp: kFrameRate
METRES_PER_MM = 0.001         # sevenscenes_source.cpp: kMetresPerMillimetre
MAX_VALID_MM = 65534          # 65535 = "no depth"
EDGE_DEPTH_GAP_M = 0.05       # frame_resample.cpp: kEdgeDepthGapM
DEPTH_CUTOFF_M = 8.0          # slam/preprocess.h: PreprocessOptions::depth_cutoff_m
DEFAULT_INTRINSICS = (585.0, 585.0, 320.0, 240.0)


def die(code, message):
    print("open3d_odometry.py: " + message, file=sys.stderr)
    sys.exit(code)


try:
    import numpy as np
    import open3d as o3d
except ImportError as exc:  # the bash driver checks this too and skips with exit 2
    die(2, "cannot import %s (Debian: apt-get install python3-open3d; run with /usr/bin/python3)" % exc.name)


def parse_args():
    p = argparse.ArgumentParser(description="Open3D hybrid RGB-D odometry on a 7-Scenes folder "
                                            "(see the header of this file).")
    p.add_argument("--data", required=True, help="7-Scenes sequence folder (frame-NNNNNN.*)")
    p.add_argument("--frames", type=int, default=0, help="at most N frames from frame 0; default all")
    p.add_argument("--resolution", default="320x240", help="working resolution WxH; default 320x240")
    p.add_argument("--out", default="", help="TUM trajectory to write")
    p.add_argument("--stats", default="", help="JSON summary to write")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    a = p.parse_args()
    try:
        w, h = (int(v) for v in a.resolution.lower().split("x"))
    except ValueError:
        die(2, "--resolution: '%s' is not WxH" % a.resolution)
    if w <= 0 or h <= 0:
        die(2, "--resolution: '%s' is not WxH" % a.resolution)
    if a.frames < 0:
        die(2, "--frames must be positive")
    a.width, a.height = w, h
    return a


def read_numbers(path, count):
    values = []
    with open(path) as f:
        for line in f:
            line = line.split("#", 1)[0]
            values.extend(float(v) for v in line.split())
    if len(values) != count:
        die(1, "%s: expected %d numbers, found %d" % (path, count, len(values)))
    return values


def list_frames(data):
    """Frame i's (colour, depth, pose or None) paths, numbered from 0 without gaps."""
    names = set(os.listdir(data))
    frames = []
    while True:
        stem = os.path.join(data, "frame-%06d" % len(frames))
        base = os.path.basename(stem)
        if base + ".depth.png" not in names:
            break
        if base + ".color.jpg" in names:
            color = stem + ".color.jpg"
        elif base + ".color.png" in names:
            color = stem + ".color.png"
        else:
            die(1, "'%s.color.jpg' missing" % stem)
        pose = stem + ".pose.txt" if base + ".pose.txt" in names else None
        frames.append((color, stem + ".depth.png", pose))
    return frames


def read_pose(path):
    m = np.array(read_numbers(path, 16), dtype=np.float64).reshape(4, 4)
    if np.abs(m[3] - [0, 0, 0, 1]).max() > 1e-6:
        die(1, "%s: last row of the pose is not 0 0 0 1" % path)
    return m


def box_shrink_color(rgb, f):
    """uint8 HxWx3 -> (H/f)x(W/f)x3, f x f box average rounded as OpenCV's INTER_AREA."""
    if f == 1:
        return rgb
    h, w = rgb.shape[0] // f, rgb.shape[1] // f
    s = rgb.reshape(h, f, w, f, 3).astype(np.uint32).sum(axis=(1, 3))
    if f == 2:
        return ((s + 2) >> 2).astype(np.uint8)  # OpenCV's resizeAreaFast for a 2x shrink
    return np.clip(np.rint(s.astype(np.float32) * np.float32(1.0 / (f * f))), 0, 255).astype(np.uint8)


def shrink_depth(depth, f):
    """float32 metres (0 = none) -> (H/f)x(W/f): per f x f block, the mean of the valid depths within
    EDGE_DEPTH_GAP_M of the block's nearest valid depth, summed in the C++ loop order (float32)."""
    if f == 1:
        return depth
    h, w = depth.shape[0] // f, depth.shape[1] // f
    blocks = depth.reshape(h, f, w, f)
    taps = [blocks[:, j, :, i] for j in range(f) for i in range(f)]  # row-major, as the C++ loops
    inf = np.float32(np.inf)
    nearest = np.full((h, w), inf, dtype=np.float32)
    for z in taps:
        nearest = np.minimum(nearest, np.where(z > 0, z, inf))
    gap = np.float32(EDGE_DEPTH_GAP_M)
    total = np.zeros((h, w), dtype=np.float32)
    count = np.zeros((h, w), dtype=np.int32)
    for z in taps:
        keep = (z > 0) & (z - nearest < gap)
        total = total + np.where(keep, z, np.float32(0))
        count += keep
    out = np.zeros((h, w), dtype=np.float32)
    np.divide(total, count.astype(np.float32), out=out, where=count > 0)
    return out


def load_frame(color_path, depth_path, f):
    rgb = np.asarray(o3d.io.read_image(color_path))
    raw = np.asarray(o3d.io.read_image(depth_path))
    if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
        die(1, "%s: not an 8-bit RGB image" % color_path)
    if raw.ndim != 2 or raw.dtype != np.uint16:
        die(1, "%s: not a 16-bit single-channel PNG" % depth_path)
    if rgb.shape[:2] != raw.shape:
        die(1, "%s is %dx%d but %s is %dx%d" % (color_path, rgb.shape[1], rgb.shape[0],
                                                depth_path, raw.shape[1], raw.shape[0]))
    valid = (raw > 0) & (raw <= MAX_VALID_MM)
    depth = np.where(valid, raw.astype(np.float32) * np.float32(METRES_PER_MM), np.float32(0))
    return box_shrink_color(rgb, f), shrink_depth(depth, f)


def to_rgbd(rgb, depth):
    return o3d.geometry.RGBDImage.create_from_color_and_depth(
        o3d.geometry.Image(np.ascontiguousarray(rgb)), o3d.geometry.Image(np.ascontiguousarray(depth)),
        depth_scale=1.0, depth_trunc=DEPTH_CUTOFF_M, convert_rgb_to_intensity=True)


def quaternion_xyzw(r):
    """Unit quaternion (x, y, z, w) with w >= 0 of a rotation matrix."""
    t = r[0, 0] + r[1, 1] + r[2, 2]
    if t > 0:
        s = 2.0 * math.sqrt(1.0 + t)
        q = [(r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s, 0.25 * s]
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = 2.0 * math.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2])
        q = [0.25 * s, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s, (r[2, 1] - r[1, 2]) / s]
    elif r[1, 1] > r[2, 2]:
        s = 2.0 * math.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2])
        q = [(r[0, 1] + r[1, 0]) / s, 0.25 * s, (r[1, 2] + r[2, 1]) / s, (r[0, 2] - r[2, 0]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1])
        q = [(r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, 0.25 * s, (r[1, 0] - r[0, 1]) / s]
    q = np.array(q)
    q /= np.linalg.norm(q)
    return -q if q[3] < 0 else q


def orthonormalize(pose):
    """Re-project the rotation of a chained pose onto SO(3) (drift of 1000 float products)."""
    u, _, vt = np.linalg.svd(pose[:3, :3])
    r = u @ vt
    if np.linalg.det(r) < 0:
        u[:, 2] = -u[:, 2]
        r = u @ vt
    out = pose.copy()
    out[:3, :3] = r
    return out


def main():
    a = parse_args()
    if not os.path.isdir(a.data):
        die(2, "data folder '%s' not found" % a.data)
    frames = list_frames(a.data)
    if not frames:
        die(1, "'%s': no frame-NNNNNN.depth.png files" % a.data)
    if a.frames:
        frames = frames[:a.frames]

    intr_file = os.path.join(a.data, "camera-intrinsics.txt")
    if os.path.exists(intr_file):
        k = read_numbers(intr_file, 9)
        fx, fy, cx, cy = k[0], k[4], k[2], k[5]
    else:
        fx, fy, cx, cy = DEFAULT_INTRINSICS
    raw0 = np.asarray(o3d.io.read_image(frames[0][1]))
    src_h, src_w = raw0.shape[:2]
    if src_w % a.width or src_h % a.height or src_w // a.width != src_h // a.height:
        die(2, "--resolution %dx%d: only integer shrink factors of the source's %dx%d are supported"
            % (a.width, a.height, src_w, src_h))
    f = src_w // a.width
    # Intrinsics::scaled_to, in float32 like the C++ struct.
    sx = np.float32(a.width) / np.float32(src_w)
    sy = np.float32(a.height) / np.float32(src_h)
    half = np.float32(0.5)
    kfx, kfy = float(np.float32(fx) * sx), float(np.float32(fy) * sy)
    kcx = float((np.float32(cx) + half) * sx - half)
    kcy = float((np.float32(cy) + half) * sy - half)
    intrinsic = o3d.camera.PinholeCameraIntrinsic(a.width, a.height, kfx, kfy, kcx, kcy)
    option = o3d.pipelines.odometry.OdometryOption()
    jacobian = o3d.pipelines.odometry.RGBDOdometryJacobianFromHybridTerm()
    threads = os.environ.get("OMP_NUM_THREADS", "")
    if not a.quiet:
        print("open3d %s, OMP_NUM_THREADS=%s, %d frames, %dx%d -> %dx%d, fx %.3f fy %.3f cx %.3f cy %.3f, "
              "depth cut-off %.1f m" % (o3d.__version__, threads, len(frames), src_w, src_h, a.width, a.height,
                                        kfx, kfy, kcx, kcy, DEPTH_CUTOFF_M), file=sys.stderr)

    identity = np.eye(4)
    pose = read_pose(frames[0][2]) if frames[0][2] else identity.copy()
    poses = [pose]
    odometry_ms = []
    odometry_cpu_ms = []  # process CPU time, all threads: the call's cost even when the cores are shared
    prepare_ms = []
    failed = []
    previous = None
    for idx, (color_path, depth_path, _) in enumerate(frames):
        t0 = time.perf_counter()
        rgb, depth = load_frame(color_path, depth_path, f)
        current = to_rgbd(rgb, depth)
        prepare_ms.append((time.perf_counter() - t0) * 1e3)
        if previous is not None:
            t0, c0 = time.perf_counter(), time.process_time()
            ok, motion, _ = o3d.pipelines.odometry.compute_rgbd_odometry(
                current, previous, intrinsic, identity, jacobian, option)
            odometry_ms.append((time.perf_counter() - t0) * 1e3)
            odometry_cpu_ms.append((time.process_time() - c0) * 1e3)
            if not ok:
                failed.append(idx)
                motion = identity
            pose = orthonormalize(pose @ motion)
            poses.append(pose)
        previous = current
        if not a.quiet and (idx + 1) % 100 == 0:
            print("  frame %d/%d, odometry median %.1f ms, failures %d"
                  % (idx + 1, len(frames), float(np.median(odometry_ms)), len(failed)), file=sys.stderr)

    if a.out:
        os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
        with open(a.out, "w") as out:
            out.write("# Open3D %s frame-to-frame RGB-D odometry (hybrid term), camera to world\n"
                      "# timestamp tx ty tz qx qy qz qw\n" % o3d.__version__)
            for idx, p in enumerate(poses):
                q = quaternion_xyzw(p[:3, :3])
                t = p[:3, 3]
                out.write("%.6f %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n"
                          % (idx / FRAME_RATE_HZ, t[0], t[1], t[2], q[0], q[1], q[2], q[3]))

    ms = np.array(odometry_ms) if odometry_ms else np.zeros(1)
    cpu = np.array(odometry_cpu_ms) if odometry_cpu_ms else np.zeros(1)
    summary = {
        "open3d_version": o3d.__version__,
        "omp_num_threads": threads,
        "frames": len(frames),
        "odometry_calls": len(odometry_ms),
        "resolution": [a.width, a.height],
        "intrinsics": {"fx": kfx, "fy": kfy, "cx": kcx, "cy": kcy},
        "depth_cutoff_m": DEPTH_CUTOFF_M,
        "odometry_median_ms": float(np.median(ms)),
        "odometry_mean_ms": float(np.mean(ms)),
        "odometry_p95_ms": float(np.percentile(ms, 95)),
        "odometry_max_ms": float(np.max(ms)),
        "odometry_cpu_median_ms": float(np.median(cpu)),
        "odometry_cpu_mean_ms": float(np.mean(cpu)),
        "prepare_median_ms": float(np.median(prepare_ms)),
        "failures": len(failed),
        "failed_frames": failed,
        "trajectory": os.path.abspath(a.out) if a.out else None,
    }
    if a.stats:
        with open(a.stats, "w") as out:
            json.dump(summary, out, indent=1)
            out.write("\n")
    print("frames %d (odometry calls %d)" % (len(frames), len(odometry_ms)))
    print("odometry_ms median %.2f mean %.2f p95 %.2f max %.2f  (compute_rgbd_odometry only)"
          % (summary["odometry_median_ms"], summary["odometry_mean_ms"], summary["odometry_p95_ms"],
             summary["odometry_max_ms"]))
    print("odometry_cpu_ms median %.2f mean %.2f  (CPU time of the process, all threads; with OMP_NUM_THREADS=1 "
          "it is close to the wall time unless other jobs share the cores)"
          % (summary["odometry_cpu_median_ms"], summary["odometry_cpu_mean_ms"]))
    print("prepare_ms median %.2f  (read + resample + RGBDImage, not counted)" % summary["prepare_median_ms"])
    print("failures %d%s" % (len(failed), (" (frames " + " ".join(map(str, failed[:20]))
                                          + (" ..." if len(failed) > 20 else "") + ")") if failed else ""))
    if a.out:
        print("trajectory: %s" % a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
