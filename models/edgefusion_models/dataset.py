"""Training and validation data: labelled RGB-D frames from EdgeFusion's synthetic room generator.

Each sequence is one random room (`synthetic:random?seed=S`) rendered at 320x240 by
`edgefusion convert`, resampled by the runtime's own resampler to the network input (160x120), and
written as a TUM RGB-D folder with labels/. The seeds of the three splits never overlap:
  train       seeds 1..TRAIN_SEQUENCES, TRAIN_FRAMES frames each (many short sequences: rooms,
              not frames, are what the network must generalise over)
  validation  seeds 9001..9000+VAL_SEQUENCES, EVAL_FRAMES each (model selection and the
              quantiser's calibration)
  test        seeds 7001..7000+TEST_SEQUENCES, EVAL_FRAMES each (the accuracy figures of the model
              card; training and calibration never read them)
Every third sequence follows the planar robot trajectory, the others the hand-held loop; every fifth
has the sensor noise off. Rooms differ in kind, size, layout, materials and lighting (seeded).
"""
import os
import subprocess
from concurrent.futures import ThreadPoolExecutor

import cv2
import numpy as np

from .net import INPUT_HEIGHT, INPUT_WIDTH

TRAIN_SEQUENCES = 360
TRAIN_FRAMES = 14
VAL_SEQUENCES = 12
TEST_SEQUENCES = 24
EVAL_FRAMES = 40
RENDER_SIZE = "320x240"

SPLIT_SEEDS = {
    "train": range(1, 1 + TRAIN_SEQUENCES),
    "val": range(9001, 9001 + VAL_SEQUENCES),
    "test": range(7001, 7001 + TEST_SEQUENCES),
}


def frames_of(seed):
    return TRAIN_FRAMES if seed in SPLIT_SEEDS["train"] else EVAL_FRAMES


def sequence_uri(seed, camera="ideal", layout="walls", handheld="loop"):
    """The source URI of one sequence; `camera` is the synthetic source's colour camera (ideal: the
    renderer's images, the shipped model's data; kinect: blur, vignetting, exposure, noise);
    `layout` its room layout (walls: the shipped model's data; island: furniture in the middle
    too, for the hand-held sequences only: on many robot paths none fits); `handheld` the
    hand-held trajectory (loop: the shipped model's data; inspect: half of the hand-held
    sequences, those of odd seeds, turn to the near wall and back, the other half keep the loop)."""
    frames = frames_of(seed)
    trajectory = "robot" if seed % 3 == 0 else "loop"
    if handheld == "inspect" and trajectory == "loop" and seed % 2 == 1:
        trajectory = "inspect"
    noise = 0 if seed % 5 == 4 else 1
    uri = f"synthetic:random?seed={seed}&frames={frames}&size={RENDER_SIZE}&trajectory={trajectory}&noise={noise}"
    if camera != "ideal":
        uri += f"&camera={camera}"
    if layout != "walls" and trajectory != "robot":
        uri += f"&layout={layout}"
    return uri


def render_sequence(edgefusion, seed, out_dir, camera="ideal", layout="walls", handheld="loop"):
    """Writes one sequence as a TUM folder (skipped when it is already complete)."""
    folder = os.path.join(out_dir, f"seed{seed:05d}")
    if os.path.exists(os.path.join(folder, "done")):
        return folder
    subprocess.run([edgefusion, "convert", "--source", sequence_uri(seed, camera, layout, handheld),
                    "--resolution", f"{INPUT_WIDTH}x{INPUT_HEIGHT}", "--to", "tum:" + folder],
                   check=True, stdout=subprocess.DEVNULL)
    open(os.path.join(folder, "done"), "w").close()
    return folder


def load_tum_folder(folder):
    """(rgb uint8 N,H,W,3; depth_m float32 N,H,W; labels uint8 N,H,W) of a TUM folder with labels/."""
    names = sorted(f for f in os.listdir(os.path.join(folder, "rgb")) if f.endswith(".png"))
    rgb, depth, labels = [], [], []
    for n in names:
        bgr = cv2.imread(os.path.join(folder, "rgb", n), cv2.IMREAD_COLOR)
        d = cv2.imread(os.path.join(folder, "depth", n), cv2.IMREAD_UNCHANGED)
        lab = cv2.imread(os.path.join(folder, "labels", n), cv2.IMREAD_UNCHANGED)
        if bgr is None or d is None or lab is None:
            raise RuntimeError(f"{folder}: frame {n}: rgb, depth or label image missing or unreadable")
        rgb.append(bgr[:, :, ::-1])
        depth.append(d.astype(np.float32) / 5000.0)  # TUM depth PNG: 5000 per metre
        labels.append(lab)
    return np.stack(rgb), np.stack(depth), np.stack(labels)


def build_split(edgefusion, split, data_dir, jobs=2, camera="ideal", layout="walls", handheld="loop"):
    """Renders (if needed) and loads one split; caches the arrays in data_dir/<split>.npz. Use one
    data_dir per camera, layout and hand-held trajectory: the caches do not record which rendered them."""
    cache = os.path.join(data_dir, f"{split}.npz")
    if os.path.exists(cache):
        z = np.load(cache)
        return z["rgb"], z["depth"], z["labels"]
    seq_dir = os.path.join(data_dir, "sequences")
    os.makedirs(seq_dir, exist_ok=True)
    with ThreadPoolExecutor(jobs) as pool:
        folders = list(pool.map(lambda s: render_sequence(edgefusion, s, seq_dir, camera, layout, handheld), SPLIT_SEEDS[split]))
    parts = [load_tum_folder(f) for f in folders]
    rgb, depth, labels = (np.concatenate([p[i] for p in parts]) for i in range(3))
    np.savez(cache, rgb=rgb, depth=depth, labels=labels)
    return rgb, depth, labels
