"""Calibration frames: raw network inputs N x H x W x 4 float32 (R, G, B in 0..255, depth in metres,
0 = invalid) from an .npz (rgb, depth arrays, as dataset.py caches them) or from any EdgeFusion
source URI, materialised with `edgefusion convert --to tum:DIR`.
"""
import glob
import os
import shutil
import subprocess
import tempfile

import cv2
import numpy as np

TUM_DEPTH_PER_METRE = 5000.0


def evenly_spaced(count, limit, centred=False):
    """Indices of at most `limit` frames spread over `count` (all when limit is None): the first and
    the last frame and evenly between them; centred: the middle frame of each of `limit` equal
    segments, floor((k + 1/2) count / limit), which keeps away from the frames every count/limit-th
    (1000 frames: 100 -> 5, 15, ..., 995; 40 -> 12, 37, 62, ..., none a multiple of 10)."""
    if limit is None or limit >= count:
        return np.arange(count)
    if centred:
        return np.unique((2 * np.arange(limit, dtype=np.int64) + 1) * count // (2 * limit))
    return np.unique(np.linspace(0, count - 1, limit).round().astype(np.int64))


def raw_frames(rgb, depth):
    """N x H x W x 4 float32 from rgb uint8 N x H x W x 3 and depth float32 N x H x W (metres)."""
    if rgb.ndim != 4 or rgb.shape[3] != 3 or depth.shape != rgb.shape[:3]:
        raise ValueError(f"calibration: rgb {rgb.shape} and depth {depth.shape} do not match (N,H,W,3)/(N,H,W)")
    return np.concatenate([rgb.astype(np.float32), depth.astype(np.float32)[..., None]], axis=3)


def load_npz(path, max_frames=None):
    """Raw frames of an .npz with arrays rgb (N,H,W,3 uint8) and depth (N,H,W float32 metres)."""
    z = np.load(path)
    for key in ("rgb", "depth"):
        if key not in z:
            raise ValueError(f"{path}: no array '{key}' (needs rgb N,H,W,3 uint8 and depth N,H,W float32 metres)")
    idx = evenly_spaced(len(z["rgb"]), max_frames)
    return raw_frames(z["rgb"][idx], z["depth"][idx])


def _list_file(folder, name):
    """Image paths listed in a TUM rgb.txt / depth.txt (lines "timestamp path"), in order."""
    path = os.path.join(folder, name)
    if not os.path.exists(path):
        sub = name.split(".")[0]
        return [os.path.join(sub, f) for f in sorted(os.listdir(os.path.join(folder, sub))) if f.endswith(".png")]
    out = []
    with open(path) as f:
        for line in f:
            parts = line.split()
            if len(parts) >= 2 and not line.startswith("#"):
                out.append(parts[1])
    return out


def load_tum(folder, max_frames=None, centred=False):
    """Raw frames of a TUM RGB-D folder as `edgefusion convert` writes it (rgb/ and depth/ PNGs in
    the same order, depth 16-bit at 5000 per metre); max_frames, centred: as evenly_spaced."""
    rgb_files, depth_files = _list_file(folder, "rgb.txt"), _list_file(folder, "depth.txt")
    if len(rgb_files) != len(depth_files) or not rgb_files:
        raise ValueError(f"{folder}: {len(rgb_files)} colour and {len(depth_files)} depth images")
    rgb, depth = [], []
    for i in evenly_spaced(len(rgb_files), max_frames, centred):
        bgr = cv2.imread(os.path.join(folder, rgb_files[i]), cv2.IMREAD_COLOR)
        d = cv2.imread(os.path.join(folder, depth_files[i]), cv2.IMREAD_UNCHANGED)
        if bgr is None or d is None:
            raise ValueError(f"{folder}: frame {i}: unreadable image")
        rgb.append(bgr[:, :, ::-1])
        depth.append(d.astype(np.float32) / TUM_DEPTH_PER_METRE)
    return raw_frames(np.stack(rgb), np.stack(depth))


def _has_convert(binary):
    """True when `binary convert --help` works (build folders may hold an older app without it)."""
    try:
        return subprocess.run([binary, "convert", "--help"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                              timeout=30).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


def find_edgefusion(explicit=None):
    """The edgefusion binary: the explicit path, else the first of $EDGEFUSION, PATH and the builds
    of this checkout (build/*/firmware_app/edgefusion) that has the convert command."""
    if explicit:
        if not (os.path.isfile(explicit) and os.access(explicit, os.X_OK)):
            raise FileNotFoundError(f"edgefusion binary not found: {explicit}")
        return explicit
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    builds = sorted(glob.glob(os.path.join(root, "build", "*", "firmware_app", "edgefusion")))
    for cand in [os.environ.get("EDGEFUSION"), shutil.which("edgefusion")] + builds:
        if cand and os.path.isfile(cand) and os.access(cand, os.X_OK) and _has_convert(cand):
            return cand
    raise FileNotFoundError("no edgefusion binary with the convert command: pass --edgefusion PATH or set EDGEFUSION")


def load_uri(uri, width, height, frames=None, edgefusion=None, centred=False):
    """Raw frames of an EdgeFusion source URI at width x height. "npz:FILE" reads an .npz directly
    (its frames must already have that size); anything else goes through
    `edgefusion convert --source URI --resolution WxH --to tum:TMP`. frames: at most that many,
    spread evenly over the source (centred: see evenly_spaced)."""
    if uri.startswith("npz:"):
        if centred:
            raise ValueError(f"{uri}: centred frame selection applies to sources, not .npz files")
        x = load_npz(uri[4:], frames)
        if x.shape[1:3] != (height, width):
            raise ValueError(f"{uri}: frames are {x.shape[2]}x{x.shape[1]}, the network takes {width}x{height}")
        return x
    binary = find_edgefusion(edgefusion)
    with tempfile.TemporaryDirectory(prefix="ef_calib_") as tmp:
        out = os.path.join(tmp, "frames")
        cmd = [binary, "convert", "--source", uri, "--resolution", f"{width}x{height}", "--to", "tum:" + out, "--quiet"]
        res = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        if res.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed ({res.returncode}): {res.stderr.strip() or res.stdout.strip()}")
        return load_tum(out, frames, centred)  # spread over the whole source, not its first frames
