"""Exports a trained EdgeSegNet to the int8 model file (.efm) and golden files for the C++ test.

  /usr/bin/python3 -m edgefusion_models.export --checkpoint CKPT.pt --calibration-npz FILE.npz \\
      --out MODEL.efm --golden-dir DIR [--max-calibration N]
  /usr/bin/python3 -m edgefusion_models.export --random-init SEED --out MODEL.efm --golden-dir DIR

The checkpoint is a dict whose "model" entry is an EdgeSegNet state_dict (train.py). The .npz holds
rgb (N,120,160,3 uint8), depth (N,120,160 float32 metres) and labels (unused here). --random-init
exports a randomly initialised network calibrated on random frames (test fixtures); the output is
byte-for-byte reproducible for a given seed.
"""
import argparse
import os
import sys

import torch

from . import calibration, net, random_init
from .from_torch import from_edgesegnet
from .pipeline import export_graph

DEFAULT_MAX_CALIBRATION = 128
RANDOM_CALIBRATION_FRAMES = 4


def load_checkpoint(path):
    """An eval-mode EdgeSegNet from a checkpoint dict {"model": state_dict} (or a bare state_dict)."""
    ckpt = torch.load(path, map_location="cpu")
    state = ckpt["model"] if isinstance(ckpt, dict) and "model" in ckpt else ckpt
    if "classifier.weight" not in state:
        raise ValueError(f"{path}: not an EdgeSegNet checkpoint (no classifier.weight in the state dict)")
    # The layer widths (net.EdgeSegNet's widths; 24, 32, 64, 128 for the shipped network) from the
    # stem's and the first pointwise convolution of enc1, enc2 and enc3.
    widths = tuple(int(state[k].shape[0]) for k in ("stem.0.weight", "enc1.1.0.weight", "enc2.0.1.0.weight",
                                                     "enc3.0.1.0.weight"))
    model = net.EdgeSegNet(num_classes=state["classifier.weight"].shape[0], widths=widths)
    model.load_state_dict(state)
    return model.eval()


def parse_args(argv):
    p = argparse.ArgumentParser(prog="python3 -m edgefusion_models.export", description=__doc__.split("\n")[0])
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--checkpoint", help="train.py checkpoint (.pt): dict with 'model' = EdgeSegNet state_dict")
    src.add_argument("--random-init", type=int, metavar="SEED", help="random network and random calibration frames")
    p.add_argument("--calibration-npz", help="calibration frames: .npz with rgb (N,H,W,3 uint8), depth (N,H,W metres)")
    p.add_argument("--out", required=True, help="output model file (.efm)")
    p.add_argument("--golden-dir", help="write golden files (input, output rows, manifest) for the C++ test here")
    p.add_argument("--max-calibration", type=int, default=None,
                   help=f"calibrate on at most N frames spread over the file (default {DEFAULT_MAX_CALIBRATION}; "
                        f"random init: {RANDOM_CALIBRATION_FRAMES})")
    p.add_argument("--golden-frame", type=int, default=0, help="calibration frame used as golden input (default 0)")
    p.add_argument("--quiet", action="store_true", help="no summary lines")
    p.add_argument("--concat", choices=("share", "requantize"), default="share",
                   help="concat inputs share the output's quantisation (default) or are requantised")
    args = p.parse_args(argv)
    if args.checkpoint and not args.calibration_npz:
        p.error("--checkpoint needs --calibration-npz")
    return args


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    if args.random_init is not None:
        count = args.max_calibration or RANDOM_CALIBRATION_FRAMES
        rgb, depth = random_init.random_frames(args.random_init, count)
        raw = random_init.raw_input(rgb, depth)
        model = random_init.random_edgesegnet(args.random_init, raw)
        name = f"edgesegnet-random-{args.random_init}"
        description = random_init.describe(args.random_init) + f", {count} random calibration frames"
    else:
        model = load_checkpoint(args.checkpoint)
        raw = calibration.load_npz(args.calibration_npz, args.max_calibration or DEFAULT_MAX_CALIBRATION)
        name = "edgesegnet"
        description = (f"EdgeSegNet {os.path.basename(args.checkpoint)}, calibrated on {len(raw)} frames of "
                       f"{os.path.basename(args.calibration_npz)}")
    if not 0 <= args.golden_frame < len(raw):
        raise SystemExit(f"--golden-frame {args.golden_frame}: only {len(raw)} calibration frames")
    g = from_edgesegnet(model)
    export_graph(g, raw, args.out, args.golden_dir, args.golden_frame,
                 description + f"; golden input = calibration frame {args.golden_frame}", name=name,
                 depth_max=net.DEPTH_MAX_M, concat_policy=args.concat,
                 log=(lambda *a: None) if args.quiet else print)
    return 0


if __name__ == "__main__":
    sys.exit(main())
