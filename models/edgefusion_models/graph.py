"""A small float IR mirroring the int8 runtime's layer types, and its numpy float forward pass.

Tensors are NHWC (the batch dimension is free in the forward pass, 1 in the model file). A Graph is a
list of Nodes in execution order; every node reads named tensors and writes one. Node kinds:

  conv2d            weight [Cout][kh][kw][Cin]      bias [Cout]
  depthwise_conv2d  weight [C][kh][kw]              bias [C]
  pointwise_conv2d  weight [Cout][Cin]              bias [Cout]
  add, concat (channels), clamp, max_pool, avg_pool (padding excluded from the count),
  upsample (factor f, mode "nearest" or "bilinear" with half-pixel centres), softmax (channels)
  resize_bilinear   to size = (H, W), any size up or down, TensorFlow align_corners
  avg_pool with kernel = its input's (H, W), stride 1, no padding is a global pool (up to 256 x 256)
  batchnorm         per-channel y = x * bn_scale + bn_shift; only while importing (passes.py folds it)

conv2d / depthwise / pointwise / add / clamp carry an output range act_range = (lo, hi) in real
units: ReLU is (0, inf), ReLU6 (0, 6), none (-inf, inf). The quantiser folds it into the integer
[out_min, out_max] of the layer (docs/model_format.md 3.2).

The input of the graph is the *normalised* image, (raw - mean) * scale per channel, with mean and
scale kept on the graph (they go to the model file's META).
"""
import math
from dataclasses import dataclass, field
from typing import List, Optional, Tuple

import numpy as np

from . import float_ops

INF = math.inf
CONV_KINDS = ("conv2d", "depthwise_conv2d", "pointwise_conv2d")
KINDS = CONV_KINDS + ("add", "concat", "clamp", "max_pool", "avg_pool", "upsample", "resize_bilinear", "softmax",
                      "batchnorm")
# Kinds whose output range (activation) the runtime can apply; avg_pool and concat have none.
RANGED_KINDS = CONV_KINDS + ("add", "clamp")


class UnsupportedModelError(ValueError):
    """A model (or one of its operators) the int8 runtime cannot run; the message names the node."""


@dataclass
class Node:
    name: str
    kind: str
    inputs: List[str]
    output: str
    weight: Optional[np.ndarray] = None       # float32, layout per kind (module docstring)
    bias: Optional[np.ndarray] = None         # float32 [Cout]
    kernel: Tuple[int, int] = (1, 1)          # (kh, kw): convolutions and pools
    stride: Tuple[int, int] = (1, 1)
    dilation: Tuple[int, int] = (1, 1)
    pads: Tuple[int, int, int, int] = (0, 0, 0, 0)  # top, left, bottom, right
    act_range: Tuple[float, float] = (-INF, INF)  # output range in real units
    factor: int = 1                           # upsample
    mode: str = "nearest"                     # upsample: "nearest" or "bilinear"
    size: Tuple[int, int] = (0, 0)            # resize_bilinear: output (H, W)
    # Convolutions imported from int8 weights (TFLite): the per-output-channel scale of that grid,
    # so that the quantiser keeps the file's integers instead of rounding them onto a new grid.
    weight_scale: Optional[np.ndarray] = None
    bn_scale: Optional[np.ndarray] = None     # batchnorm (transient)
    bn_shift: Optional[np.ndarray] = None


@dataclass
class Graph:
    name: str
    input: str
    input_shape: Tuple[int, int, int]         # (H, W, C)
    output: str
    nodes: List[Node]
    mean: List[float]
    scale: List[float]
    class_names: List[str] = field(default_factory=list)
    # Optional: per output channel, the class id it contributes to in the runtime's label set (the
    # model file's CMAP, docs/model_format.md), and the names of those target classes. Both empty
    # (output channel k is class k) or both given.
    class_map: List[int] = field(default_factory=list)
    target_class_names: List[str] = field(default_factory=list)

    def producer(self):
        """{tensor name: node} for every produced tensor."""
        return {n.output: n for n in self.nodes}

    def consumers(self):
        """{tensor name: [nodes reading it]}."""
        out = {}
        for n in self.nodes:
            for t in n.inputs:
                out.setdefault(t, []).append(n)
        return out


def window_out(n, k, stride, dil, pad_a, pad_b):
    span = dil * (k - 1) + 1
    return (n + pad_a + pad_b - span) // stride + 1 if n + pad_a + pad_b >= span else 0


def infer_shapes(g: Graph):
    """{tensor name: (H, W, C)}; raises UnsupportedModelError on an inconsistent node."""
    shapes = {g.input: tuple(g.input_shape)}
    for n in g.nodes:
        def bad(what):
            raise UnsupportedModelError(f"node '{n.name}' ({n.kind}): {what}")
        for t in n.inputs:
            if t not in shapes:
                bad(f"input '{t}' is not produced before this node")
        if n.output in shapes:
            bad(f"output '{n.output}' is produced twice")
        ins = [shapes[t] for t in n.inputs]
        h, w, c = ins[0]
        if n.kind in CONV_KINDS or n.kind in ("max_pool", "avg_pool"):
            dil = n.dilation if n.kind in CONV_KINDS else (1, 1)
            oh = window_out(h, n.kernel[0], n.stride[0], dil[0], n.pads[0], n.pads[2])
            ow = window_out(w, n.kernel[1], n.stride[1], dil[1], n.pads[1], n.pads[3])
            if oh < 1 or ow < 1:
                bad(f"window larger than the padded input {h}x{w}")
            if n.kind == "conv2d":
                cout, kh, kw, cin = n.weight.shape
                if cin != c or (kh, kw) != tuple(n.kernel):
                    bad(f"weight shape {n.weight.shape} does not fit input channels {c}")
                c = cout
            elif n.kind == "depthwise_conv2d":
                if n.weight.shape != (c, n.kernel[0], n.kernel[1]):
                    bad(f"weight shape {n.weight.shape} does not fit input channels {c}")
            elif n.kind == "pointwise_conv2d":
                if n.weight.shape[1] != c:
                    bad(f"weight shape {n.weight.shape} does not fit input channels {c}")
                c = n.weight.shape[0]
            shapes[n.output] = (oh, ow, c)
        elif n.kind == "add":
            if len(ins) != 2 or ins[0] != ins[1]:
                bad(f"needs two inputs of one shape, has {ins}")
            shapes[n.output] = ins[0]
        elif n.kind == "concat":
            if any(s[:2] != (h, w) for s in ins):
                bad(f"inputs differ spatially: {ins}")
            shapes[n.output] = (h, w, sum(s[2] for s in ins))
        elif n.kind == "upsample":
            shapes[n.output] = (h * n.factor, w * n.factor, c)
        elif n.kind == "resize_bilinear":
            oh, ow = n.size
            if oh < 1 or ow < 1:
                bad(f"output size {n.size} must be at least 1 x 1")
            shapes[n.output] = (oh, ow, c)
        elif n.kind in ("clamp", "softmax", "batchnorm"):
            shapes[n.output] = ins[0]
        else:
            bad("unknown kind")
    if g.output not in shapes:
        raise UnsupportedModelError(f"graph output '{g.output}' is never produced")
    return shapes


def normalise(g: Graph, raw):
    """(raw - mean) * scale per channel, float32: raw N x H x W x C (R, G, B 0..255, depth metres)."""
    mean = np.asarray(g.mean, dtype=np.float32)
    scale = np.asarray(g.scale, dtype=np.float32)
    return (np.asarray(raw, dtype=np.float32) - mean) * scale


def run_node(n: Node, ins):
    """The float32 result of one node on its input arrays (each N x H x W x C)."""
    lo, hi = n.act_range
    if n.kind == "conv2d":
        y = float_ops.conv2d(ins[0], n.weight, n.bias, n.stride, n.dilation, n.pads)
    elif n.kind == "depthwise_conv2d":
        y = float_ops.depthwise_conv2d(ins[0], n.weight, n.bias, n.stride, n.dilation, n.pads)
    elif n.kind == "pointwise_conv2d":
        y = float_ops.pointwise_conv2d(ins[0], n.weight, n.bias)
    elif n.kind == "add":
        y = ins[0] + ins[1]
    elif n.kind == "concat":
        y = np.concatenate(ins, axis=3)
    elif n.kind == "clamp":
        y = ins[0]
    elif n.kind == "max_pool":
        y = float_ops.max_pool(ins[0], n.kernel, n.stride, n.pads)
    elif n.kind == "avg_pool":
        y = float_ops.avg_pool(ins[0], n.kernel, n.stride, n.pads)
    elif n.kind == "upsample":
        y = (float_ops.upsample_nearest(ins[0], n.factor) if n.mode == "nearest"
             else float_ops.upsample_bilinear(ins[0], n.factor))
    elif n.kind == "resize_bilinear":
        y = float_ops.resize_bilinear(ins[0], n.size)
    elif n.kind == "softmax":
        y = float_ops.softmax(ins[0])
    elif n.kind == "batchnorm":
        y = ins[0] * n.bn_scale.astype(np.float32) + n.bn_shift.astype(np.float32)
    else:
        raise UnsupportedModelError(f"node '{n.name}': unknown kind {n.kind}")
    if lo > -INF or hi < INF:
        y = np.clip(y, np.float32(lo), np.float32(hi))
    return y.astype(np.float32, copy=False)


def forward(g: Graph, x, keep=False, observer=None):
    """Float forward of normalised input x (N x H x W x C). Returns the output array, or the dict of
    every tensor when keep. observer(name, array) is called on the input and each produced tensor
    (calibration statistics without keeping the tensors)."""
    x = np.asarray(x, dtype=np.float32)
    if x.ndim == 3:
        x = x[None]
    vals = {g.input: x}
    if observer:
        observer(g.input, x)
    # Free each tensor after its last reader when not keeping them (calibration of big batches).
    last_use = {}
    for i, n in enumerate(g.nodes):
        for t in n.inputs:
            last_use[t] = i
    for i, n in enumerate(g.nodes):
        vals[n.output] = run_node(n, [vals[t] for t in n.inputs])
        if observer:
            observer(n.output, vals[n.output])
        if not keep:
            for t in set(n.inputs):
                if last_use.get(t) == i and t != g.output:
                    del vals[t]
    return vals if keep else vals[g.output]
