"""Float IR + calibration frames -> .efm file and golden files: the steps both command lines share
(export.py for PyTorch checkpoints, import_onnx.py for ONNX files)."""
import copy
import os

import numpy as np

from . import efm, golden, int8_ref
from .graph import forward, normalise
from .quantize import DEFAULT_DEPTH_MAX_M, quantize


def export_graph(g, raw, out_path, golden_dir=None, golden_index=0, description="", name=None,
                 depth_max=DEFAULT_DEPTH_MAX_M, concat_policy="share", log=print, bias_correction=False,
                 clip="minmax", gain_correction=False):
    """Quantises g on raw frames (N x H x W x C), writes out_path and, when golden_dir is given,
    the golden files of frame golden_index. Returns the QModel. bias_correction, gain_correction:
    see quantize.correct_biases (changes g's biases, and with the gains its weights); clip: the
    activation ranges (quantize.calibrate)."""
    g_float = copy.deepcopy(g) if bias_correction else g  # the network before the corrections
    qm = quantize(g, raw, depth_max=depth_max, concat_policy=concat_policy, name=name,
                  bias_correction=bias_correction, clip=clip, gain_correction=gain_correction)
    os.makedirs(os.path.dirname(os.path.abspath(out_path)), exist_ok=True)
    data = efm.write(out_path, qm)
    log(f"{out_path}: {len(qm.layers)} layers, {len(qm.tensors)} tensors, {len(data)} bytes "
        f"(calibrated on {len(raw)} frames)")
    if golden_dir:
        frame = raw[golden_index]
        input_q = int8_ref.quantize_input(frame, qm)
        probs, tensors = int8_ref.run(qm, input_q, keep_tensors=True)
        golden.write(golden_dir, qm, data, input_q, probs, tensors, description or g.name)
        float_probs = forward(g_float, normalise(g_float, frame[None]))[0]
        agree = float(np.mean(probs.argmax(2) == float_probs.argmax(2)))
        log(f"{golden_dir}: golden of frame {golden_index}; int8 and float argmax agree on {100 * agree:.1f}% "
            f"of pixels, max |p_int8 - p_float| = {float(np.abs(probs - float_probs).max()):.3f}")
    return qm
