"""How closely an imported int8 model follows the float network it came from, on real frames.

  /usr/bin/python3 -m edgefusion_models.agreement --tflite FILE --model MODEL.efm --source URI \\
      [--every 10] [--frames N] [--edgefusion PATH] [--json OUT]

The frames of the source are converted to the model's input size by `edgefusion convert` (the
resampling `run` and `segment` apply), every `every`-th is kept. The float side is tflite_ref.py, the
file's own operators in numpy, up to the logits at the model's output size, on the frames normalised
as the file expects (from_tflite's DeepLab normalisation, the importer's: v / 127.5 - 1, whatever
mean the int8 model stores, which quantize.integer_input_mean may have moved into its first bias);
their softmax is summed into the model's target classes with its class map. The int8 side is the C++ runtime
(`edgefusion segment --probabilities`). Reported: the share of pixels whose argmax agrees, over all
frames, the median per frame and the worst frame, and the mean absolute probability difference.
"""
import argparse
import glob
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

from . import calibration, efm, tflite, tflite_ref
from .from_tflite import DEEPLAB_MEAN, DEEPLAB_SCALE


def softmax(x):
    e = np.exp(x - x.max(axis=-1, keepdims=True))
    return e / e.sum(axis=-1, keepdims=True)


def float_probs(model, frames, size, class_map, n_targets, mean=127.5, scale=1.0 / 127.5):
    """Target-class probabilities of the float reference at stride 4 (before the final resize)."""
    out = []
    stop = len(model.operators) - 2  # the last op resizes the logits to the input size
    for f in frames:
        x = ((f[..., :3].astype(np.float32) - mean) * np.float32(scale))[None]
        logits = tflite_ref.run(model, x, size=size, stop_at=stop)[0]
        p = softmax(logits.astype(np.float64))
        q = np.zeros(p.shape[:2] + (n_targets,))
        for c, t in enumerate(class_map):
            q[..., t] += p[..., c]
        out.append(q)
    return np.stack(out)


def int8_probs(binary, model_path, tum_dir, n, every):
    with tempfile.TemporaryDirectory(prefix="ef_agree_") as tmp:
        cmd = [binary, "segment", "--model", model_path, "--source", "tum:" + tum_dir, "--out", tmp,
               "--probabilities", "--threads", "1", "--every", str(every)]
        r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        if r.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)}: {r.stderr.strip()}")
        files = sorted(glob.glob(os.path.join(tmp, "probabilities", "*.npy")))
        if len(files) != n:
            raise RuntimeError(f"segment wrote {len(files)} probability files for {n} frames")
        return np.stack([np.load(f) for f in files])


def main(argv=None):
    p = argparse.ArgumentParser(prog="python3 -m edgefusion_models.agreement", description=__doc__.split("\n")[0])
    p.add_argument("--tflite", required=True)
    p.add_argument("--model", required=True, help="the imported .efm")
    p.add_argument("--source", required=True, help="EdgeFusion source URI (e.g. 7scenes:DIR)")
    p.add_argument("--every", type=int, default=10, help="every K-th frame (default 10)")
    p.add_argument("--frames", type=int, help="at most N frames of the source before thinning")
    p.add_argument("--edgefusion", help="edgefusion binary (default: $EDGEFUSION, PATH, build/*/)")
    p.add_argument("--json", help="also write the figures as JSON here")
    a = p.parse_args(argv)
    qm = efm.read(a.model)
    t_in = qm.tensors[qm.input_tensor]
    h, w = t_in.h, t_in.w
    binary = calibration.find_edgefusion(a.edgefusion)
    with tempfile.TemporaryDirectory(prefix="ef_agree_src_") as tmp:
        out = os.path.join(tmp, "frames")
        cmd = [binary, "convert", "--source", a.source, "--resolution", f"{w}x{h}", "--to", "tum:" + out, "--quiet"]
        if a.frames:
            cmd += ["--frames", str(a.frames)]
        r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        if r.returncode != 0:
            raise SystemExit(f"{' '.join(cmd)}: {r.stderr.strip()}")
        frames = calibration.load_tum(out)[::a.every]
        q = int8_probs(binary, a.model, out, len(frames), a.every)
    model = tflite.read(a.tflite)
    class_map = qm.class_map if qm.class_map else list(range(q.shape[-1]))
    # The network as published: its own input normalisation, not the int8 model's (an integer mean).
    f = float_probs(model, frames, (h, w), class_map, q.shape[-1], DEEPLAB_MEAN[0], DEEPLAB_SCALE[0])
    if f.shape != q.shape:
        raise SystemExit(f"float {f.shape} and int8 {q.shape} outputs differ in shape")
    agree = f.argmax(-1) == q.argmax(-1)
    per_frame = agree.reshape(len(frames), -1).mean(axis=1)
    res = {"model": os.path.basename(a.model), "input": f"{w}x{h}", "output": f"{q.shape[2]}x{q.shape[1]}",
           "frames": len(frames), "every": a.every, "agreement": float(agree.mean()),
           "median_frame_agreement": float(np.median(per_frame)), "worst_frame_agreement": float(per_frame.min()),
           "mean_abs_prob_diff": float(np.abs(f - q).mean())}
    print(f"{res['model']} at {res['input']} on {len(frames)} frames of {a.source} (every {a.every}th): argmax "
          f"agreement with the float reference {100 * res['agreement']:.2f}% of pixels (median frame "
          f"{100 * res['median_frame_agreement']:.2f}%, worst {100 * res['worst_frame_agreement']:.2f}%), "
          f"mean |p_int8 - p_float| {res['mean_abs_prob_diff']:.4f}")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(res, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
