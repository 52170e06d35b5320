"""Writes a trained EdgeSegNet checkpoint as a float ONNX model (opset 13, input "image"
1 x 4 x 120 x 160, normalised as net.py says; output "logits" 1 x 14 x 120 x 160).

    /usr/bin/python3 -m edgefusion_models.to_onnx --checkpoint checkpoints/edgesegnet.pt --out edgesegnet.onnx

The model card compares `edgefusion model import` of this file with the native export.
"""
import argparse
import warnings

import torch

from .net import INPUT_HEIGHT, INPUT_WIDTH, EdgeSegNet


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--checkpoint", required=True)
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    net = EdgeSegNet()
    net.load_state_dict(torch.load(args.checkpoint, map_location="cpu")["model"])
    net.eval()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # torch's tracer warnings about Python control flow: none here
        torch.onnx.export(net, torch.zeros(1, 4, INPUT_HEIGHT, INPUT_WIDTH), args.out, opset_version=13,
                          input_names=["image"], output_names=["logits"])
    print(f"{args.out}: EdgeSegNet from {args.checkpoint} (opset 13)")


if __name__ == "__main__":
    main()
