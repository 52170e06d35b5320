"""The quantised model: what an .efm file describes (docs/model_format.md), as Python objects.

This mirrors ef::nn::ModelDesc (src/nn/model_format.h) field for field, so that the writer (efm.py),
the integer reference (int8_ref.py) and the quantiser (quantize.py) share one description. validate()
restates the loader's checks so that the exporter fails here, with a readable message, instead of
writing a file the C++ runtime refuses.
"""
import math
from dataclasses import dataclass, field
from enum import IntEnum
from typing import List, Optional

import numpy as np

# Limits of docs/model_format.md (the loader's constants in src/nn/model_format.h).
MAX_TENSORS = 4096
MAX_LAYERS = 4096
MAX_DIM = 8192
MAX_TENSOR_ELEMENTS = 1 << 26
MAX_CLASSES = 256
MAX_NAME_BYTES = 255
MAX_CLASS_NAME_BYTES = 63
MAX_KERNEL = 31
MAX_GLOBAL_POOL = 256   # a global avg_pool (window = input H x W, stride 1, no padding) up to 256 x 256
MAX_STRIDE = 8
MAX_DILATION = 16
MAX_PAD = 64
MAX_UPSAMPLE = 16
MAX_LAYER_INPUTS = 16
MAX_REDUCTION = 32768
MAX_ABS_BIAS = 1 << 30
FLT_MIN = 2.0 ** -126
MULTIPLIER_LIMIT = 2.0 ** 24


class DType(IntEnum):
    INT8 = 0
    FLOAT32 = 1


class LayerType(IntEnum):
    CONV2D = 0
    DEPTHWISE_CONV2D = 1
    POINTWISE_CONV2D = 2
    ADD = 3
    CONCAT = 4
    CLAMP = 5
    MAX_POOL = 6
    AVG_POOL = 7
    UPSAMPLE = 8
    SOFTMAX = 9
    RESIZE_BILINEAR = 10


CONV_TYPES = (LayerType.CONV2D, LayerType.DEPTHWISE_CONV2D, LayerType.POINTWISE_CONV2D)


class Activation(IntEnum):
    """Informative only: the arithmetic uses [out_min, out_max]."""
    NONE = 0
    RELU = 1
    RELU6 = 2
    CLAMP = 3


class UpsampleMode(IntEnum):
    NEAREST = 0
    BILINEAR = 1


@dataclass
class QTensor:
    h: int
    w: int
    c: int
    scale: float = 1.0          # stored as float32; real = scale * (q - zero_point)
    zero_point: int = 0         # [-128, 127]; float32 tensors: 0
    dtype: DType = DType.INT8
    n: int = 1

    @property
    def shape(self):
        return (self.h, self.w, self.c)

    def elements(self):
        return self.n * self.h * self.w * self.c


@dataclass
class QLayer:
    type: LayerType
    inputs: List[int]
    output: int
    act: Activation = Activation.NONE
    mode: UpsampleMode = UpsampleMode.NEAREST
    kernel_h: int = 1
    kernel_w: int = 1
    stride_h: int = 1
    stride_w: int = 1
    dilation_h: int = 1
    dilation_w: int = 1
    pad_top: int = 0
    pad_left: int = 0
    pad_bottom: int = 0
    pad_right: int = 0
    out_min: int = -128
    out_max: int = 127
    factor: int = 1
    # Convolutions only: float32 [Cout], int32 [Cout], int8 flat in the file layout
    # ([Cout][kh][kw][Cin], [C][kh][kw] or [Cout][Cin]).
    weight_scales: Optional[np.ndarray] = None
    bias: Optional[np.ndarray] = None
    weights: Optional[np.ndarray] = None
    name: str = ""              # not stored in the file: for messages and manifests


@dataclass
class QModel:
    name: str
    input_tensor: int
    output_tensor: int
    input_mean: List[float]     # per input channel, stored as float32
    input_scale: List[float]
    class_names: List[str]
    tensors: List[QTensor]
    layers: List[QLayer]
    tensor_names: List[str] = field(default_factory=list)  # not stored in the file
    # Optional class map (CMAP section, a version 2 file): per output channel the target class id,
    # and the target class names; both empty (no map, a version 1 file) or both given.
    class_map: List[int] = field(default_factory=list)
    target_class_names: List[str] = field(default_factory=list)


def f32(v):
    """The float32 value of v, as the file stores it (round to nearest even)."""
    return float(np.float32(v))


def make_multiplier(real):
    """float32(real) when it is a normal float32 below 2^24 (requantize.h make_multiplier), else None."""
    m = np.float32(real)
    if not (float(m) >= FLT_MIN) or not (float(m) < MULTIPLIER_LIMIT):
        return None
    return m


def conv_real_multiplier(s_in, w_scale, s_out):
    # double(s_in) * double(weight_scale) / double(s_out), left to right (model_format.md 3.2).
    return float(np.float32(s_in)) * float(np.float32(w_scale)) / float(np.float32(s_out))


def ratio_real_multiplier(s_a, s_out):
    # double(s_a) / double(s_out) (add 3.3, concat 3.4).
    return float(np.float32(s_a)) / float(np.float32(s_out))


def avg_real_multiplier(s_in, s_out, n):
    # (double(s_in) / double(s_out)) / double(n) (avg_pool 3.6).
    return (float(np.float32(s_in)) / float(np.float32(s_out))) / float(n)


def is_global_pool(layer, t_in):
    """An avg_pool whose window is its input's H x W, with stride 1 and no padding (model_format.h)."""
    return (layer.type == LayerType.AVG_POOL and (layer.kernel_h, layer.kernel_w) == (t_in.h, t_in.w) and
            (layer.stride_h, layer.stride_w) == (1, 1) and
            (layer.pad_top, layer.pad_left, layer.pad_bottom, layer.pad_right) == (0, 0, 0, 0))


def avg_pool_counts(layer, t_in):
    """The window counts whose multipliers the loader computes (and checks): kh*kw alone for a global
    pool, every count 1..kh*kw otherwise."""
    window = layer.kernel_h * layer.kernel_w
    return range(window, window + 1) if is_global_pool(layer, t_in) else range(1, window + 1)


def resize_tap(o, n, m):
    """docs/model_format.md 3.9 (nn/resize_taps.h): (i0, i1, w) of output index o on an axis of n
    input and m output positions, w the weight of i1 in units of 1/2048."""
    if m == 1 or n == 1:
        return 0, 0, 0
    num, den = o * (n - 1), m - 1
    i0, r = num // den, num % den
    return i0, min(i0 + 1, n - 1), (r * 2048 + den // 2) // den


def weights_per_channel(layer, cin):
    if layer.type == LayerType.CONV2D:
        return layer.kernel_h * layer.kernel_w * cin
    if layer.type == LayerType.DEPTHWISE_CONV2D:
        return layer.kernel_h * layer.kernel_w
    return cin


def window_out(n, k, stride, dil, pad_a, pad_b):
    """Output size along one axis (docs 2, LAYR), 0 when the window does not fit."""
    span = dil * (k - 1) + 1
    padded = n + pad_a + pad_b
    if padded < span:
        return 0
    return (padded - span) // stride + 1


class ModelError(ValueError):
    """A quantised model the C++ loader would refuse."""


def validate(m: QModel):
    """Raises ModelError naming the tensor or layer at fault (the loader's checks, docs section 4)."""
    def fail(where, what):
        raise ModelError(f"{m.name}: {where}: {what}")

    if len(m.name.encode()) > MAX_NAME_BYTES:
        fail("META", "model name too long")
    if not 1 <= len(m.tensors) <= MAX_TENSORS:
        fail("TENS", f"{len(m.tensors)} tensors")
    for i, t in enumerate(m.tensors):
        if t.n != 1 or not all(1 <= d <= MAX_DIM for d in t.shape) or t.elements() > MAX_TENSOR_ELEMENTS:
            fail("TENS", f"tensor {i}: shape {t.n}x{t.h}x{t.w}x{t.c}")
        if t.dtype == DType.INT8:
            s = f32(t.scale)
            if not (math.isfinite(s) and s > 0):
                fail("TENS", f"tensor {i}: scale {t.scale} not finite and positive")
            if not -128 <= t.zero_point <= 127:
                fail("TENS", f"tensor {i}: zero point {t.zero_point}")
        elif f32(t.scale) != 1.0 or t.zero_point != 0:
            fail("TENS", f"tensor {i}: float32 tensor must have scale 1 and zero point 0")
    n = len(m.tensors)
    if not (0 <= m.input_tensor < n and 0 <= m.output_tensor < n) or m.input_tensor == m.output_tensor:
        fail("META", "input/output tensor ids")
    tin, tout = m.tensors[m.input_tensor], m.tensors[m.output_tensor]
    if tin.dtype != DType.INT8 or tout.dtype != DType.FLOAT32:
        fail("META", "input must be int8 and output float32")
    if len(m.input_mean) != tin.c or len(m.input_scale) != tin.c:
        fail("META", "input normalisation needs one mean and scale per input channel")
    for c in range(tin.c):
        if not (math.isfinite(f32(m.input_mean[c])) and math.isfinite(f32(m.input_scale[c]))) or f32(m.input_scale[c]) == 0:
            fail("META", f"input normalisation of channel {c}")
    if not 1 <= len(m.class_names) <= MAX_CLASSES or len(m.class_names) != tout.c:
        fail("META", f"{len(m.class_names)} class names for {tout.c} output channels")
    for i, cn in enumerate(m.class_names):
        if not 1 <= len(cn.encode()) <= MAX_CLASS_NAME_BYTES:
            fail("META", f"class {i} name empty or longer than {MAX_CLASS_NAME_BYTES} bytes")
    _validate_class_map(m, tout, fail)
    if not 1 <= len(m.layers) <= MAX_LAYERS:
        fail("LAYR", f"{len(m.layers)} layers")
    produced = [False] * n
    produced[m.input_tensor] = True
    for li, l in enumerate(m.layers):
        where = f"layer {li} ({LayerType(l.type).name.lower()}{' ' + l.name if l.name else ''})"
        for t in l.inputs:
            if not 0 <= t < n or not produced[t]:
                fail("LAYR", f"{where}: input tensor {t} not produced by an earlier layer")
        if not 0 <= l.output < n or produced[l.output]:
            fail("LAYR", f"{where}: output tensor {l.output} out of range or produced twice")
        _validate_layer(m, l, lambda what: fail("LAYR", f"{where}: {what}"))
        produced[l.output] = True
    if not produced[m.output_tensor]:
        fail("LAYR", "no layer produces the output tensor")


def _validate_class_map(m, tout, fail):
    cmap, targets = list(m.class_map), list(m.target_class_names)
    if not cmap and not targets:
        return
    if not cmap or not targets:
        fail("CMAP", f"a class map needs target class names and the reverse ({len(cmap)} map entries, "
                     f"{len(targets)} target names)")
    if len(targets) > MAX_CLASSES:
        fail("CMAP", f"{len(targets)} target classes, allowed 1..{MAX_CLASSES}")
    for i, cn in enumerate(targets):
        if not 1 <= len(cn.encode()) <= MAX_CLASS_NAME_BYTES:
            fail("CMAP", f"target class {i} name empty or longer than {MAX_CLASS_NAME_BYTES} bytes")
    if len(cmap) != tout.c:
        fail("CMAP", f"{len(cmap)} map entries but the output has {tout.c} channels")
    for k, t in enumerate(cmap):
        if not 0 <= int(t) < len(targets):
            fail("CMAP", f"output channel {k} maps to class {t}, beyond the {len(targets)} target classes")


def _validate_layer(m, l, bad):
    ins = [m.tensors[t] for t in l.inputs]
    out = m.tensors[l.output]
    in0 = ins[0] if ins else None
    lo_in, hi_in = (2, 2) if l.type == LayerType.ADD else ((1, MAX_LAYER_INPUTS) if l.type == LayerType.CONCAT else (1, 1))
    if not lo_in <= len(ins) <= hi_in:
        bad(f"{len(ins)} inputs")
    if any(t.dtype != DType.INT8 for t in ins):
        bad("inputs must be int8")
    if l.type == LayerType.SOFTMAX:
        if out.dtype != DType.FLOAT32 or l.output != m.output_tensor:
            bad("softmax must produce the float32 model output")
    elif out.dtype != DType.INT8:
        bad("output must be int8")

    def same_quant(a, b):
        return f32(a.scale) == f32(b.scale) and a.zero_point == b.zero_point

    def check_range():
        if not (-128 <= l.out_min <= l.out_max <= 127):
            bad(f"output range [{l.out_min}, {l.out_max}]")

    def check_window(conv):
        max_k = MAX_GLOBAL_POOL if is_global_pool(l, in0) else MAX_KERNEL
        if not (1 <= l.kernel_h <= max_k and 1 <= l.kernel_w <= max_k):
            bad(f"kernel {l.kernel_h}x{l.kernel_w} outside 1..{max_k}" +
                ("" if max_k == MAX_GLOBAL_POOL or l.type != LayerType.AVG_POOL else
                 f" (up to {MAX_GLOBAL_POOL} only for a global average pool: window = input H x W, stride 1, "
                 "no padding)"))
        if not (1 <= l.stride_h <= MAX_STRIDE and 1 <= l.stride_w <= MAX_STRIDE):
            bad("stride")
        dh, dw = (l.dilation_h, l.dilation_w) if conv else (1, 1)
        if not (1 <= dh <= MAX_DILATION and 1 <= dw <= MAX_DILATION):
            bad("dilation")
        pads = (l.pad_top, l.pad_left, l.pad_bottom, l.pad_right)
        if not all(0 <= p <= MAX_PAD for p in pads):
            bad("padding")
        if not conv and (l.pad_top >= l.kernel_h or l.pad_bottom >= l.kernel_h or
                         l.pad_left >= l.kernel_w or l.pad_right >= l.kernel_w):
            bad("pool padding must be smaller than the window")
        oh = window_out(in0.h, l.kernel_h, l.stride_h, dh, l.pad_top, l.pad_bottom)
        ow = window_out(in0.w, l.kernel_w, l.stride_w, dw, l.pad_left, l.pad_right)
        if (oh, ow) != (out.h, out.w):
            bad(f"output {out.h}x{out.w} but the window gives {oh}x{ow}")

    if l.type in CONV_TYPES:
        if l.type == LayerType.POINTWISE_CONV2D and (
                (l.kernel_h, l.kernel_w, l.stride_h, l.stride_w) != (1, 1, 1, 1) or
                any((l.pad_top, l.pad_left, l.pad_bottom, l.pad_right))):
            bad("pointwise convolution must be 1x1, stride 1, no padding")
        check_window(True)
        check_range()
        if l.type == LayerType.DEPTHWISE_CONV2D and out.c != in0.c:
            bad("depthwise output channels differ from input channels")
        k = weights_per_channel(l, in0.c)
        if k > MAX_REDUCTION:
            bad(f"reduction of {k} terms per output")
        if l.weight_scales is None or len(l.weight_scales) != out.c or l.bias is None or len(l.bias) != out.c:
            bad("one weight scale and bias per output channel")
        if l.weights is None or l.weights.size != k * out.c:
            bad(f"needs {k * out.c} weights")
        if np.any(np.asarray(l.weights) == -128):
            bad("weight -128 (symmetric weights are in [-127, 127])")
        if np.any(np.abs(np.asarray(l.bias, dtype=np.int64)) > MAX_ABS_BIAS):
            bad("bias beyond +-2^30")
        for c, ws in enumerate(l.weight_scales):
            if not (math.isfinite(f32(ws)) and f32(ws) > 0):
                bad(f"weight scale of channel {c}")
            if make_multiplier(conv_real_multiplier(in0.scale, ws, out.scale)) is None:
                bad(f"multiplier of channel {c} is not a normal float32 below 2^24")
    else:
        if l.weight_scales is not None or l.bias is not None or l.weights is not None:
            bad("has weights but the layer type takes none")
    if l.type == LayerType.ADD:
        if not (ins[0].shape == ins[1].shape == out.shape):
            bad("shapes differ")
        check_range()
        for t in ins:
            if make_multiplier(ratio_real_multiplier(t.scale, out.scale)) is None:
                bad("input/output scale ratio is not a normal float32 below 2^24")
    elif l.type == LayerType.CONCAT:
        if any((t.h, t.w) != (out.h, out.w) for t in ins) or sum(t.c for t in ins) != out.c:
            bad("concat shapes")
        for t in ins:
            if make_multiplier(ratio_real_multiplier(t.scale, out.scale)) is None:
                bad("input/output scale ratio is not a normal float32 below 2^24")
    elif l.type == LayerType.CLAMP:
        if in0.shape != out.shape or not same_quant(in0, out):
            bad("clamp needs equal shapes and quantisation")
        check_range()
    elif l.type in (LayerType.MAX_POOL, LayerType.AVG_POOL):
        check_window(False)
        if out.c != in0.c:
            bad("pool changes channels")
        if l.type == LayerType.MAX_POOL and not same_quant(in0, out):
            bad("max_pool needs equal input and output quantisation")
        if l.type == LayerType.AVG_POOL:
            for k in avg_pool_counts(l, in0):
                if make_multiplier(avg_real_multiplier(in0.scale, out.scale, k)) is None:
                    bad(f"multiplier over a window of {k} is not a normal float32 below 2^24")
    elif l.type == LayerType.UPSAMPLE:
        if not 1 <= l.factor <= MAX_UPSAMPLE or l.mode not in (0, 1):
            bad("upsampling factor or mode")
        if (in0.h * l.factor, in0.w * l.factor, in0.c) != out.shape or not same_quant(in0, out):
            bad("upsample needs out = in x factor and equal quantisation")
    elif l.type == LayerType.RESIZE_BILINEAR:
        if in0.c != out.c:
            bad(f"changes channels {in0.c} -> {out.c}")
        if not same_quant(in0, out):
            bad("input and output quantisation must match")
    elif l.type == LayerType.SOFTMAX:
        if in0.shape != out.shape:
            bad("softmax shapes")
