"""Imports a float ONNX segmentation model into the int8 model file (.efm).

  /usr/bin/python3 -m edgefusion_models.import_onnx --onnx FILE --calibration URI --out MODEL.efm \\
      [--edgefusion PATH] [--frames N] [--mean R,G,B,D] [--scale R,G,B,D] [--golden-dir DIR]

The ONNX input is N x 4 x H x W (N = 1 or symbolic): the image normalised with --mean / --scale
(default: net.py INPUT_MEAN / INPUT_SCALE), R, G, B in 0..255 and depth in metres. The calibration
URI is any EdgeFusion source (tum:DIR, 7scenes:DIR, "synthetic:random?seed=9001&frames=40&size=320x240",
...), converted to W x H by `edgefusion convert`; "npz:FILE" reads frames from an .npz (rgb, depth)
instead. Supported operators: see from_onnx.py; anything else is reported by node name.
"""
import argparse
import os
import sys

from . import calibration
from .from_onnx import from_onnx
from .graph import UnsupportedModelError
from .pipeline import export_graph
from .quantize import DEFAULT_DEPTH_MAX_M

DEFAULT_FRAMES = 40


def _floats(text):
    return [float(v) for v in text.split(",")]


def parse_args(argv):
    p = argparse.ArgumentParser(prog="python3 -m edgefusion_models.import_onnx", description=__doc__.split("\n")[0])
    p.add_argument("--onnx", required=True, help="float ONNX model (input N x 4 x H x W, normalised)")
    p.add_argument("--calibration", required=True, help="EdgeFusion source URI of calibration frames, or npz:FILE")
    p.add_argument("--out", required=True, help="output model file (.efm)")
    p.add_argument("--edgefusion", help="edgefusion binary for `convert` (default: $EDGEFUSION, PATH, build/*/)")
    p.add_argument("--frames", type=int, default=DEFAULT_FRAMES,
                   help=f"calibrate on N frames spread over the source (default {DEFAULT_FRAMES})")
    p.add_argument("--mean", type=_floats, help="input normalisation mean per channel, comma-separated")
    p.add_argument("--scale", type=_floats, help="input normalisation scale per channel, comma-separated")
    p.add_argument("--depth-max", type=float, default=DEFAULT_DEPTH_MAX_M,
                   help=f"largest depth (metres) the int8 input represents (default {DEFAULT_DEPTH_MAX_M})")
    p.add_argument("--class-names", help="comma-separated class names (default net.py's when 14 classes)")
    p.add_argument("--name", help="model name stored in the file (default the ONNX file name without extension)")
    p.add_argument("--golden-dir", help="also write golden files (first calibration frame) for the C++ test")
    p.add_argument("--quiet", action="store_true", help="no summary lines")
    p.add_argument("--concat", choices=("share", "requantize"), default="share",
                   help="concat inputs share the output's quantisation (default) or are requantised")
    return p.parse_args(argv)


def progress(args, text):
    """One line per stage on stderr, so that a long import shows where it is."""
    if not args.quiet:
        print(f"model import: {text}", file=sys.stderr, flush=True)


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    name = args.name or os.path.splitext(os.path.basename(args.onnx))[0]
    if not os.path.isfile(args.onnx):
        print(f"{args.onnx}: no such file", file=sys.stderr)
        return 2
    progress(args, f"reading {args.onnx}")
    try:
        g = from_onnx(args.onnx, args.mean, args.scale,
                      args.class_names.split(",") if args.class_names else None, name)
    except UnsupportedModelError as e:
        print(f"{args.onnx}: {e}", file=sys.stderr)
        return 2
    except Exception as e:  # noqa: BLE001 - onnx's protobuf parser and checker raise types of their own
        print(f"{args.onnx}: not a readable ONNX model ({type(e).__name__}: {e})", file=sys.stderr)
        return 2
    h, w, _ = g.input_shape
    progress(args, f"calibration: {args.frames} frames of {args.calibration} at {w}x{h}")
    try:
        raw = calibration.load_uri(args.calibration, w, h, args.frames, args.edgefusion)
    except (OSError, RuntimeError, ValueError) as e:
        print(f"{args.calibration}: calibration frames: {e}", file=sys.stderr)
        return 1
    progress(args, f"quantising to int8 on {len(raw)} frames and writing {args.out}")
    export_graph(g, raw, args.out, args.golden_dir, 0,
                 f"{g.name} imported from ONNX, calibrated on {len(raw)} frames; golden input = calibration frame 0",
                 depth_max=args.depth_max, concat_policy=args.concat,
                 log=(lambda *a: None) if args.quiet else print)
    return 0


if __name__ == "__main__":
    sys.exit(main())
