"""PyTorch module (eval mode) -> float IR, by tracing forward() with torch.fx.

Tracing follows forward() exactly (its wiring, concatenation order, upsampling), so EdgeSegNet's
skip connections need no hand-written copy here; a change to net.py is picked up, and an operator the
runtime lacks fails with the traced node's name. BatchNorm2d is folded into the preceding
convolution, ReLU / ReLU6 / clamp become output ranges, F.interpolate bilinear (align_corners=False)
becomes a bilinear upsample, torch.cat a concat, and a softmax over channels is appended as the
output stage when forward() returns logits.
"""
import math
import operator

import numpy as np
import torch
import torch.fx
import torch.nn as nn
import torch.nn.functional as F

from . import net
from .graph import INF, Graph, Node, UnsupportedModelError
from .passes import GraphBuilder, conv_node, finish


def _pair(v):
    return tuple(v) if isinstance(v, (tuple, list)) else (v, v)


def _np(t):
    return t.detach().cpu().numpy().astype(np.float32)


class _Builder(GraphBuilder):
    def __init__(self, input_shape):
        super().__init__("input", input_shape)

    def tensor(self, fx_node, where):
        if not isinstance(fx_node, torch.fx.Node):
            raise UnsupportedModelError(f"{where}: operand {fx_node!r} is not a tensor of the graph (constants are unsupported)")
        return self.name(fx_node.name)


def _integral_factor(sf, where):
    vals = [float(v) for v in (sf if isinstance(sf, (tuple, list)) else (sf, sf))]
    if len(set(vals)) != 1 or vals[0] != math.floor(vals[0]) or not 1 <= vals[0] <= 16:
        raise UnsupportedModelError(f"{where}: scale factor {sf}; the runtime upsamples by one integer factor 1..16")
    return int(vals[0])


def _upsample(b, where, name, x, out, scale_factor, size, mode, align_corners):
    if scale_factor is None:
        if size is None:
            raise UnsupportedModelError(f"{where}: neither size nor scale_factor")
        h, w, _ = b.shapes[x]
        sh, sw = _pair(size)
        if sh % h or sw % w or sh // h != sw // w:
            raise UnsupportedModelError(f"{where}: size {size} is not one integer multiple of {h}x{w}")
        scale_factor = sh // h
    f = _integral_factor(scale_factor, where)
    if mode == "nearest":
        m = "nearest"
    elif mode == "bilinear" and not align_corners:
        m = "bilinear"
    else:
        raise UnsupportedModelError(f"{where}: mode {mode!r} align_corners={align_corners}; the runtime has nearest "
                                    "and bilinear with half-pixel centres (align_corners=False)")
    b.add(Node(name=name, kind="upsample", inputs=[x], output=out, factor=f, mode=m))


def _pool(b, where, name, kind, x, out, kernel, stride, padding, ceil_mode, dilation=1, count_include_pad=False,
          divisor_override=None):
    k = _pair(kernel)
    s = _pair(stride if stride not in (None, []) else kernel)
    p = _pair(padding)
    if _pair(dilation) != (1, 1) or divisor_override is not None:
        raise UnsupportedModelError(f"{where}: pool dilation or divisor_override")
    if kind == "avg_pool" and count_include_pad and p != (0, 0):
        raise UnsupportedModelError(f"{where}: count_include_pad=True with padding; the runtime averages over "
                                    "the positions inside the input")
    if ceil_mode:
        h, w, _ = b.shapes[x]
        for n, kk, ss, pp in ((h, k[0], s[0], p[0]), (w, k[1], s[1], p[1])):
            if (n + 2 * pp - kk) % ss:
                raise UnsupportedModelError(f"{where}: ceil_mode=True changes the output size")
    b.add(Node(name=name, kind=kind, inputs=[x], output=out, kernel=k, stride=s, pads=(p[0], p[1], p[0], p[1])))


def _conv_module(b, name, x, out, m: nn.Conv2d):
    where = f"node '{name}' (Conv2d)"
    if m.padding_mode != "zeros":
        raise UnsupportedModelError(f"{where}: padding_mode {m.padding_mode!r}; only zero padding")
    k, s, d = _pair(m.kernel_size), _pair(m.stride), _pair(m.dilation)
    if m.padding == "valid":
        pads = (0, 0, 0, 0)
    elif m.padding == "same":
        tot = [d[i] * (k[i] - 1) for i in range(2)]
        pads = (tot[0] // 2, tot[1] // 2, tot[0] - tot[0] // 2, tot[1] - tot[1] // 2)
    else:
        p = _pair(m.padding)
        pads = (p[0], p[1], p[0], p[1])
    bias = None if m.bias is None else _np(m.bias)
    b.add(conv_node(name, x, out, _np(m.weight), bias, s, d, pads, m.groups, op="Conv2d"))


def _bn_module(b, name, x, out, m: nn.BatchNorm2d):
    if not m.track_running_stats or m.running_var is None:
        raise UnsupportedModelError(f"node '{name}' (BatchNorm2d): no running statistics to fold")
    var = m.running_var.detach().double().numpy()
    mean = m.running_mean.detach().double().numpy()
    gamma = m.weight.detach().double().numpy() if m.weight is not None else np.ones_like(var)
    beta = m.bias.detach().double().numpy() if m.bias is not None else np.zeros_like(var)
    scale = gamma / np.sqrt(var + m.eps)
    b.add(Node(name=name, kind="batchnorm", inputs=[x], output=out, bn_scale=scale, bn_shift=beta - mean * scale))


def _clamp(b, name, x, out, lo, hi):
    lo = -INF if lo is None else float(lo)
    hi = INF if hi is None else float(hi)
    b.add(Node(name=name, kind="clamp", inputs=[x], output=out, act_range=(lo, hi)))


def _softmax_dim(where, dim):
    if dim not in (1, -3):
        raise UnsupportedModelError(f"{where}: softmax over dim {dim}; the runtime normalises over channels (dim 1)")


def _call_module(b, fx_node, mod):
    name, out = str(fx_node.target), fx_node.name
    where = f"node '{name}' ({type(mod).__name__})"
    if len(fx_node.args) != 1 or fx_node.kwargs:
        raise UnsupportedModelError(f"{where}: expected one tensor argument")
    x = b.tensor(fx_node.args[0], where)
    if isinstance(mod, nn.Conv2d):
        _conv_module(b, name, x, out, mod)
    elif isinstance(mod, nn.BatchNorm2d):
        _bn_module(b, name, x, out, mod)
    elif isinstance(mod, nn.ReLU):
        _clamp(b, name, x, out, 0.0, None)
    elif isinstance(mod, nn.ReLU6):
        _clamp(b, name, x, out, 0.0, 6.0)
    elif isinstance(mod, nn.Hardtanh):
        _clamp(b, name, x, out, mod.min_val, mod.max_val)
    elif isinstance(mod, nn.MaxPool2d):
        if mod.return_indices:
            raise UnsupportedModelError(f"{where}: return_indices")
        _pool(b, where, name, "max_pool", x, out, mod.kernel_size, mod.stride, mod.padding, mod.ceil_mode, mod.dilation)
    elif isinstance(mod, nn.AvgPool2d):
        _pool(b, where, name, "avg_pool", x, out, mod.kernel_size, mod.stride, mod.padding, mod.ceil_mode,
              count_include_pad=mod.count_include_pad, divisor_override=mod.divisor_override)
    elif isinstance(mod, nn.Upsample):
        _upsample(b, where, name, x, out, mod.scale_factor, mod.size, mod.mode, mod.align_corners)
    elif isinstance(mod, (nn.Identity, nn.Dropout, nn.Dropout2d)):
        b.alias[out] = x
    elif isinstance(mod, nn.Softmax):
        _softmax_dim(where, mod.dim)
        b.add(Node(name=name, kind="softmax", inputs=[x], output=out))
    else:
        raise UnsupportedModelError(f"{where}: module type not supported by the int8 runtime")


def _arg(fx_node, i, key, default=None):
    if len(fx_node.args) > i:
        return fx_node.args[i]
    return fx_node.kwargs.get(key, default)


def _call_function(b, fx_node):
    fn, name, out = fx_node.target, fx_node.name, fx_node.name
    where = f"node '{name}' ({getattr(fn, '__name__', fn)})"
    if fn is F.interpolate:
        if _arg(fx_node, 6, "antialias", False):
            raise UnsupportedModelError(f"{where}: antialias")
        _upsample(b, where, name, b.tensor(fx_node.args[0], where), out, _arg(fx_node, 2, "scale_factor"),
                  _arg(fx_node, 1, "size"), _arg(fx_node, 3, "mode", "nearest"), _arg(fx_node, 4, "align_corners"))
    elif fn is torch.cat:
        dim = _arg(fx_node, 1, "dim", 0)
        if dim not in (1, -3):
            raise UnsupportedModelError(f"{where}: concatenation along dim {dim}; the runtime concatenates channels")
        b.add(Node(name=name, kind="concat", inputs=[b.tensor(t, where) for t in fx_node.args[0]], output=out))
    elif fn in (operator.add, torch.add):
        if len(fx_node.args) != 2 or fx_node.kwargs:
            raise UnsupportedModelError(f"{where}: add with alpha or out")
        b.add(Node(name=name, kind="add", inputs=[b.tensor(a, where) for a in fx_node.args], output=out))
    elif fn in (F.relu, torch.relu):
        _clamp(b, name, b.tensor(fx_node.args[0], where), out, 0.0, None)
    elif fn is F.relu6:
        _clamp(b, name, b.tensor(fx_node.args[0], where), out, 0.0, 6.0)
    elif fn is F.hardtanh:
        _clamp(b, name, b.tensor(fx_node.args[0], where), out, _arg(fx_node, 1, "min_val", -1.0),
               _arg(fx_node, 2, "max_val", 1.0))
    elif fn is torch.clamp:
        _clamp(b, name, b.tensor(fx_node.args[0], where), out, _arg(fx_node, 1, "min"), _arg(fx_node, 2, "max"))
    elif fn in (F.softmax, torch.softmax):
        _softmax_dim(where, _arg(fx_node, 1, "dim"))
        b.add(Node(name=name, kind="softmax", inputs=[b.tensor(fx_node.args[0], where)], output=out))
    else:
        raise UnsupportedModelError(f"{where}: function not supported by the int8 runtime")


def _call_method(b, fx_node):
    name, out, meth = fx_node.name, fx_node.name, fx_node.target
    where = f"node '{name}' (Tensor.{meth})"
    x = b.tensor(fx_node.args[0], where)
    if meth == "relu":
        _clamp(b, name, x, out, 0.0, None)
    elif meth == "clamp":
        _clamp(b, name, x, out, _arg(fx_node, 1, "min"), _arg(fx_node, 2, "max"))
    elif meth == "softmax":
        _softmax_dim(where, _arg(fx_node, 1, "dim"))
        b.add(Node(name=name, kind="softmax", inputs=[x], output=out))
    else:
        raise UnsupportedModelError(f"{where}: method not supported by the int8 runtime")


def from_module(module: nn.Module, input_shape=(net.INPUT_HEIGHT, net.INPUT_WIDTH, 4), mean=net.INPUT_MEAN,
                scale=net.INPUT_SCALE, class_names=None, name="edgesegnet"):
    """The float IR of an eval-mode module taking one N x C x H x W tensor (input_shape is H, W, C)."""
    if module.training:
        raise ValueError("from_module: put the module in eval mode first (batch norm must use running statistics)")
    traced = torch.fx.symbolic_trace(module)
    mods = dict(traced.named_modules())
    b = _Builder(input_shape)
    output = None
    for fx_node in traced.graph.nodes:
        if fx_node.op == "placeholder":
            if "input" in b.alias.values():
                raise UnsupportedModelError(f"node '{fx_node.name}': more than one input")
            b.alias[fx_node.name] = "input"
        elif fx_node.op == "call_module":
            _call_module(b, fx_node, mods[fx_node.target])
        elif fx_node.op == "call_function":
            _call_function(b, fx_node)
        elif fx_node.op == "call_method":
            _call_method(b, fx_node)
        elif fx_node.op == "output":
            output = b.tensor(fx_node.args[0], "graph output")
        else:
            raise UnsupportedModelError(f"node '{fx_node.name}' ({fx_node.op}): not supported (parameters used "
                                        "directly in forward?)")
    g = Graph(name=name, input="input", input_shape=tuple(input_shape), output=output, nodes=b.nodes,
              mean=list(mean), scale=list(scale), class_names=list(class_names or []))
    return finish(g)


def from_edgesegnet(model):
    """The IR of an EdgeSegNet (net.py) with its normalisation and class names."""
    k = model.classifier.out_channels
    names = net.CLASS_NAMES if k == len(net.CLASS_NAMES) else [f"class{i}" for i in range(k)]
    return from_module(model, (net.INPUT_HEIGHT, net.INPUT_WIDTH, 4), net.INPUT_MEAN, net.INPUT_SCALE, names,
                       name="edgesegnet")
