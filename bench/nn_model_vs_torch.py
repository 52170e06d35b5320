#!/usr/bin/python3
"""Whole-network latency: EdgeFusion's int8 runtime against PyTorch's int8 backend, one thread.

    /usr/bin/python3 bench/nn_model_vs_torch.py --bench build/release/bench/bench_nn_model \
        [--checkpoint models/checkpoints/edgesegnet.pt] [--model models/edgefusion-seg.efm] [--reps 200]

The same network (EdgeSegNet, same trained weights) runs through
  - PyTorch: FX graph-mode post-training static quantisation (per-channel int8 weights, int8
    activations), engine "onednn" (else "fbgemm"), calibrated on the validation frames, and
  - EdgeFusion: bench_nn_model on the shipped .efm (best ISA path),
both on one thread (torch.set_num_threads(1); bench_nn_model is single-threaded), in one run.
Both are timed in thread CPU time (bench_nn_model's clock), median over the runs. Prints median ms
per forward pass of PyTorch and of each of our ISA paths, and each ratio (EdgeFusion / PyTorch; the
goal is at most 1.0).
PyTorch's figure includes its quantise/dequantise stubs and a float softmax; ours includes the input
quantisation and the int8 softmax output stage.
"""
import argparse
import os
import re
import subprocess
import sys
import time

import numpy as np
import torch

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "models"))
from edgefusion_models.net import INPUT_HEIGHT, INPUT_WIDTH, EdgeSegNet  # noqa: E402


class WithSoftmax(torch.nn.Module):
    def __init__(self, net):
        super().__init__()
        self.net = net

    def forward(self, x):
        return torch.softmax(self.net(x), 1)


def torch_int8(checkpoint, calib):
    from torch.ao.quantization import get_default_qconfig_mapping
    from torch.ao.quantization.quantize_fx import convert_fx, prepare_fx
    engine = "onednn" if "onednn" in torch.backends.quantized.supported_engines else "fbgemm"
    torch.backends.quantized.engine = engine
    net = EdgeSegNet()
    if checkpoint:
        net.load_state_dict(torch.load(checkpoint, map_location="cpu")["model"])
    net.eval()
    prepared = prepare_fx(net, get_default_qconfig_mapping(engine), example_inputs=(calib[:1],))
    with torch.no_grad():
        for i in range(0, calib.shape[0], 8):
            prepared(calib[i:i + 8])
    return WithSoftmax(convert_fx(prepared)).eval(), engine


def median_ms(fn, reps, min_ms):
    """Median thread CPU time of fn() in ms over at least `reps` runs and `min_ms` of CPU time."""
    times = []
    while len(times) < reps or sum(times) < min_ms:
        t0 = time.thread_time_ns()
        fn()
        times.append((time.thread_time_ns() - t0) / 1e6)
    return float(np.median(times)), len(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bench", required=True, help="path of bench_nn_model")
    ap.add_argument("--checkpoint", default="models/checkpoints/edgesegnet.pt")
    ap.add_argument("--model", default="models/edgefusion-seg.efm")
    ap.add_argument("--calibration-npz", default="", help="val.npz of the training data (random input if empty)")
    ap.add_argument("--reps", type=int, default=200)
    ap.add_argument("--min-ms", type=float, default=2000)
    args = ap.parse_args()

    torch.set_num_threads(1)
    torch.manual_seed(0)
    if args.calibration_npz:
        from edgefusion_models.train import to_input
        z = np.load(args.calibration_npz)
        calib = to_input(z["rgb"][:64], z["depth"][:64])
    else:
        calib = torch.rand(64, 4, INPUT_HEIGHT, INPUT_WIDTH) * 2 - 1
    qnet, engine = torch_int8(args.checkpoint if os.path.exists(args.checkpoint) else "", calib)
    x = calib[:1].contiguous()
    with torch.no_grad():
        for _ in range(10):
            qnet(x)
        torch_ms, n = median_ms(lambda: qnet(x), args.reps, args.min_ms)
    print(f"pytorch {torch.__version__} int8 ({engine}), 1 thread: {torch_ms:.3f} ms median over {n} runs")

    out = subprocess.run([args.bench, "--model", args.model, "--reps", str(args.reps)], check=True,
                         capture_output=True, text=True).stdout
    print(out, end="")
    rows = re.findall(r"^  (scalar|sse41|avx2|avxvnni|avx512vnni|neon|neondot)\s+([0-9.]+)\s+[0-9.]+%", out, re.M)
    if not rows:
        sys.exit("no timed ISA rows in bench_nn_model's output")
    for isa, ms in rows:
        ours = float(ms)
        print(f"edgefusion {isa:<10} {ours:8.3f} ms vs pytorch {torch_ms:.3f} ms: ratio {ours / torch_ms:.2f}x "
              f"(goal <= 1.0)")


if __name__ == "__main__":
    main()
