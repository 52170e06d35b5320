"""Imports a float TFLite segmentation network (e.g. DeepLabv3-MobileNetV2) into the int8 model file.

  /usr/bin/python3 -m edgefusion_models.import_tflite --tflite FILE --calibration "URI[|URI...]" \\
      --out MODEL.efm [--input WxH] [--class-map JSON] [--labels FILE] [--frames N] [--golden-dir DIR]

The TFLite file is read by our own reader (tflite.py), folded into the runtime's layers
(from_tflite.py) at the chosen input size, calibrated on the frames of one or more EdgeFusion sources
(each converted to the input size by `edgefusion convert`; `|` separates sources, the frames are split
evenly between them, each source's the middle frames of equal segments: calibration.evenly_spaced
with centred) and quantised by the same int8 pipeline as the other importers, with the choices that
made its int8 labels follow the float network's most closely on real frames (MODEL_CARD-deeplab.md):
an integer input mean (quantize.integer_input_mean: the int8 input exact), activation ranges clipped
to their least squared error (quantize.calibrate, clip="mse"), and the bias correction with its
per-channel gain correction (quantize.correct_biases, gain=True). The class map
(JSON: {"map": {"source index": target id, ...}, "target_names" or "nyu13_names": [...]}) goes into
the model: the runtime then gives the fusion one probability per target class, the sum over its
source classes. The result is deterministic for given inputs on one machine.
"""
import argparse
import json
import os
import sys

import numpy as np

from . import calibration, net, quantize, tflite
from .from_tflite import from_tflite
from .graph import UnsupportedModelError
from .pipeline import export_graph

DEFAULT_FRAMES = 40


def parse_size(text):
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not WxH (e.g. 257x193)")
    return w, h


def read_labels(path, count):
    """Source class names: lines "index<TAB>name" (1-based ADE20K style; index 0 "other" when absent),
    the first ';'-separated synonym, at most 63 bytes."""
    names = [f"class{i}" for i in range(count)]
    names[0] = "other"
    with open(path) as f:
        for line in f:
            parts = line.rstrip("\n").split("\t")
            if len(parts) < 2 or not parts[0].strip().isdigit():
                continue
            i = int(parts[0])
            if 0 <= i < count:
                names[i] = parts[1].split(";")[0].strip()[:63] or names[i]
    return names


def read_class_map(path, count):
    """(class_map list of `count` target ids, target names) from the JSON file."""
    with open(path) as f:
        doc = json.load(f)
    mapping = doc.get("map")
    if not isinstance(mapping, dict):
        raise ValueError(f"{path}: no \"map\" object (source index -> target id)")
    targets = doc.get("target_names") or doc.get("nyu13_names")
    if not isinstance(targets, list) or not targets:
        raise ValueError(f"{path}: no \"target_names\" list")
    cmap = []
    for i in range(count):
        if str(i) not in mapping:
            raise ValueError(f"{path}: source class {i} has no target (the network has {count} outputs)")
        t = mapping[str(i)]
        if not isinstance(t, int) or not 0 <= t < len(targets):
            raise ValueError(f"{path}: source class {i} -> {t!r}, not a target id 0..{len(targets) - 1}")
        cmap.append(t)
    extra = [k for k in mapping if not k.isdigit() or int(k) >= count]
    if extra:
        raise ValueError(f"{path}: map entries {extra[:5]} are not output channels 0..{count - 1}")
    if len(targets) == net.NUM_CLASSES:
        targets = list(net.CLASS_NAMES)  # the runtime's own names for the NYUv2 13 (+ unknown)
    return cmap, [str(t)[:63] for t in targets]


def load_calibration(uris, w, h, frames, edgefusion):
    """Raw frames (N x H x W x 4) of every source, `frames` in all, split evenly; of each source the
    middle frames of equal segments (of 1000 frames, 40: 12, 37, 62, ...; 100: 5, 15, ...: none of
    them one of the frames every 10th from the first, on which agreement.py measures)."""
    parts = [u for u in uris.split("|") if u]
    if not parts:
        raise ValueError("no calibration source")
    out = []
    for k, uri in enumerate(parts):
        n = frames // len(parts) + (1 if k < frames % len(parts) else 0)
        out.append(calibration.load_uri(uri, w, h, max(n, 1), edgefusion, centred=True))
    return np.concatenate(out, axis=0)


def parse_args(argv):
    p = argparse.ArgumentParser(prog="python3 -m edgefusion_models.import_tflite", description=__doc__.split("\n")[0])
    p.add_argument("--tflite", required=True, help="float (or dynamic-range int8 weight) TFLite segmentation network")
    p.add_argument("--calibration", required=True, help="EdgeFusion source URIs of calibration frames, '|' between them")
    p.add_argument("--out", required=True, help="output model file (.efm)")
    p.add_argument("--input", type=parse_size, help="network input WxH (default the file's); each side 8k+1")
    p.add_argument("--class-map", help="JSON: source class index -> target class id, and the target names")
    p.add_argument("--labels", help="source class names, lines 'index<TAB>name'")
    p.add_argument("--frames", type=int, default=DEFAULT_FRAMES, help=f"calibration frames in all (default {DEFAULT_FRAMES})")
    p.add_argument("--name", help="model name stored in the file (default the file name without extension)")
    p.add_argument("--edgefusion", help="edgefusion binary for `convert` (default: $EDGEFUSION, PATH, build/*/)")
    p.add_argument("--golden-dir", help="also write golden files (first calibration frame) for the C++ test")
    p.add_argument("--quiet", action="store_true", help="no summary lines")
    return p.parse_args(argv)


def build_graph(args):
    """The float graph with names, class names and class map set."""
    model = tflite.read(args.tflite)
    size = (args.input[1], args.input[0]) if args.input else None
    name = args.name or os.path.splitext(os.path.basename(args.tflite))[0]
    g = from_tflite(model, size, name=name)
    nclass = len(g.class_names)
    if args.labels:
        g.class_names = read_labels(args.labels, nclass)
    if args.class_map:
        g.class_map, g.target_class_names = read_class_map(args.class_map, nclass)
    return g


def progress(args, text):
    """One line per stage on stderr, so that a long import shows where it is."""
    if not args.quiet:
        print(f"model import: {text}", file=sys.stderr, flush=True)


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    if not os.path.isfile(args.tflite):
        print(f"{args.tflite}: no such file", file=sys.stderr)
        return 2
    progress(args, f"reading {args.tflite}")
    try:
        g = build_graph(args)
    except (UnsupportedModelError, tflite.TFLiteError) as e:
        text = str(e)  # the reader's messages may name the file already
        print(text if text.startswith(args.tflite) else f"{args.tflite}: {text}", file=sys.stderr)
        return 2
    except (OSError, ValueError) as e:
        print(f"{e}", file=sys.stderr)
        return 2
    quantize.integer_input_mean(g)
    h, w, _ = g.input_shape
    progress(args, f"calibration: {args.frames} frames of {args.calibration} at {w}x{h}")
    try:
        raw = load_calibration(args.calibration, w, h, args.frames, args.edgefusion)
    except (OSError, RuntimeError, ValueError) as e:
        print(f"{args.calibration}: calibration frames: {e}", file=sys.stderr)
        return 1
    raw = raw[..., :g.input_shape[2]]  # an RGB network takes R, G, B only
    progress(args, f"quantising to int8 on {len(raw)} frames and writing {args.out}")
    export_graph(g, raw, args.out, args.golden_dir, 0,
                 f"{g.name} imported from TFLite at {w}x{h}, calibrated on {len(raw)} frames; "
                 "golden input = calibration frame 0",
                 log=(lambda *a: None) if args.quiet else print, bias_correction=True, clip="mse",
                 gain_correction=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
