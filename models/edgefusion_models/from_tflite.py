"""TFLite graph -> the float IR (graph.py), at any input size the network's alignment allows.

What the file spells out in pieces is folded into the runtime's layers:
- DEQUANTIZE of a constant, and int8 / per-channel weights used directly by CONV_2D ("dynamic range"
  quantisation): the weights are dequantised to float here, and the node keeps the scale of their int8
  grid (Node.weight_scale), so the quantiser keeps the file's integers (a new per-channel grid would
  round every weight a second time: on 7-Scenes frames that alone cost 6 points of argmax agreement).
- SPACE_TO_BATCH_ND -> DEPTHWISE_CONV_2D (VALID) -> BATCH_TO_SPACE_ND: one depthwise convolution
  with dilation = the block size and the space-to-batch's base padding (its padding minus the crop of
  the batch-to-space), which is exactly what TensorFlow rewrote the atrous convolution from.
- MUL by a per-channel constant then ADD of a per-channel constant (the batch normalisation TensorFlow
  could not fold through the space-to-batch pair, the graph's ten MULs): folded into the convolution
  before them (scale into its weights and bias, shift into its bias), the ADD's activation fused.
- RESIZE_BILINEAR to its own input size: dropped (an identity). The last RESIZE_BILINEAR, logits to
  the full input size, is dropped too: the model's output stays at stride 4 and the runtime resamples
  class probabilities to any frame size itself (`keep_final_resize` keeps it).
- The graph ends in logits: the softmax output stage is appended (passes.finish).
Any other operator, or one of these in a pattern the runtime cannot run, raises UnsupportedModelError
naming the operator, its index and its tensors.
"""
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from . import tflite
from .graph import INF, Graph, Node, UnsupportedModelError
from .passes import finish
from .tflite_ref import OUTPUT_STRIDE, SizeMap, same_pads

ACT_RANGES = {"NONE": (-INF, INF), "RELU": (0.0, INF), "RELU6": (0.0, 6.0), "RELU_N1_TO_1": (-1.0, 1.0)}

# DeepLab's input normalisation: x / 127.5 - 1 on R, G, B in 0..255.
DEEPLAB_MEAN = [127.5, 127.5, 127.5]
DEEPLAB_SCALE = [1.0 / 127.5] * 3


def _act(op, m):
    a = op.options.get("activation", "NONE")
    if a not in ACT_RANGES:
        raise UnsupportedModelError(f"{_where(op, m)}: fused activation {a} not supported")
    return ACT_RANGES[a]


def _where(op, m):
    return (f"operator {op.index} ({op.opcode}) inputs " + ", ".join(m.describe(t) for t in op.inputs) +
            " outputs " + ", ".join(m.describe(t) for t in op.outputs))


def _tname(m, t):
    return f"t{t}:{m.tensors[t].name}"


def from_tflite(path_or_model, size: Optional[Tuple[int, int]] = None, class_names: Optional[Sequence[str]] = None,
                name: Optional[str] = None, mean=None, scale=None, keep_final_resize=False) -> Graph:
    """The float IR of a TFLite segmentation network. size: input (H, W); default the file's."""
    m = path_or_model if isinstance(path_or_model, tflite.Model) else tflite.read(path_or_model)
    if len(m.inputs) != 1 or len(m.outputs) != 1:
        raise UnsupportedModelError(f"{len(m.inputs)} inputs and {len(m.outputs)} outputs; expected one of each")
    tin = m.tensors[m.inputs[0]]
    if len(tin.shape) != 4 or tin.shape[0] != 1 or tin.type_name != "FLOAT32":
        raise UnsupportedModelError(f"input {m.describe(m.inputs[0])} {tin.type_name}: expected 1 x H x W x C float32")
    file_hw = (tin.shape[1], tin.shape[2])
    hw = tuple(size) if size else file_hw
    smap = SizeMap(file_hw, hw) if hw != file_hw else None
    cin = tin.shape[3]
    mean = list(mean) if mean is not None else (DEEPLAB_MEAN if cin == 3 else None)
    scale = list(scale) if scale is not None else (DEEPLAB_SCALE if cin == 3 else None)
    if mean is None or scale is None or len(mean) != cin or len(scale) != cin:
        raise UnsupportedModelError(f"input of {cin} channels: give its normalisation mean and scale per channel")

    consts: Dict[int, np.ndarray] = {}
    grids: Dict[int, int] = {}  # constant tensor -> the int8 tensor whose grid it lies on (DEQUANTIZE)
    shapes: Dict[int, Tuple[int, int, int]] = {m.inputs[0]: (hw[0], hw[1], cin)}
    alias: Dict[int, int] = {}
    nodes: List[Node] = []
    readers: Dict[int, int] = {}
    for op in m.operators:
        for t in op.inputs:
            readers[t] = readers.get(t, 0) + 1

    def const(t, op):
        if t in consts:
            return consts[t]
        v = m.tensors[t]
        if v.data is None:
            raise UnsupportedModelError(f"{_where(op, m)}: tensor {m.describe(t)} must be a constant")
        return tflite.dequantize(v)

    def act_in(t, op):
        t = alias.get(t, t)
        if t not in shapes:
            raise UnsupportedModelError(f"{_where(op, m)}: input {m.describe(t)} is not computed before it")
        return t

    def grid(t, channels, axis):
        """Per-channel scale of the int8 grid constant t lies on, or None (float weights)."""
        v = m.tensors[grids.get(t, t)]
        if v.data is None or v.data.dtype != np.int8 or v.scale.size == 0 or np.any(v.zero_point != 0):
            return None
        if v.scale.size == 1:
            return np.full(channels, v.scale[0], np.float32)
        if v.scale.size == channels and v.quantized_dimension == axis:
            return v.scale.astype(np.float32)
        return None

    ops = m.operators
    producer_node: Dict[int, Node] = {}

    def emit(node: Node, out_t: int, shape):
        nodes.append(node)
        shapes[out_t] = shape
        producer_node[out_t] = node

    # Constants first: a DEQUANTIZE may come after the operator pattern that reads its result.
    for op in ops:
        if op.opcode == "DEQUANTIZE":
            if m.tensors[op.inputs[0]].data is None:
                raise UnsupportedModelError(f"{_where(op, m)}: DEQUANTIZE of an activation")
            consts[op.outputs[0]] = tflite.dequantize(m.tensors[op.inputs[0]])
            grids[op.outputs[0]] = op.inputs[0]
    skip = set()
    last_index = len(ops) - 1
    for op in ops:
        if op.index in skip:
            continue
        o, ins, out = op.options, op.inputs, op.outputs[0]
        kind = op.opcode
        if kind == "DEQUANTIZE":
            continue
        elif kind in ("CONV_2D", "DEPTHWISE_CONV_2D"):
            x = act_in(ins[0], op)
            h, w, c = shapes[x]
            wt = const(ins[1], op)
            b = const(ins[2], op) if len(ins) > 2 and ins[2] >= 0 else np.zeros(wt.shape[0 if kind == "CONV_2D" else 3], np.float32)
            stride = (o["stride_h"], o["stride_w"])
            dil = (o["dilation_h"], o["dilation_w"])
            kh, kw = wt.shape[1], wt.shape[2]
            if o["padding"] == "SAME":
                oh, pt, pb = same_pads(h, kh, stride[0], dil[0])
                ow, pl, pr = same_pads(w, kw, stride[1], dil[1])
            else:
                pt = pb = pl = pr = 0
                oh = (h - (kh - 1) * dil[0] - 1) // stride[0] + 1
                ow = (w - (kw - 1) * dil[1] - 1) // stride[1] + 1
            common = dict(name=_tname(m, out), inputs=[_tname(m, x)], output=_tname(m, out), bias=b.astype(np.float32),
                          kernel=(kh, kw), stride=stride, dilation=dil, pads=(pt, pl, pb, pr), act_range=_act(op, m))
            if kind == "CONV_2D":
                cout = wt.shape[0]
                if wt.shape[3] != c:
                    raise UnsupportedModelError(f"{_where(op, m)}: filter {wt.shape} over {c} input channels")
                if (kh, kw) == (1, 1) and stride == (1, 1) and (pt, pl, pb, pr) == (0, 0, 0, 0):
                    node = Node(kind="pointwise_conv2d", weight=wt.reshape(cout, c).copy(), **common)
                else:
                    node = Node(kind="conv2d", weight=np.ascontiguousarray(wt), **common)
                node.weight_scale = grid(ins[1], cout, 0)
                emit(node, out, (oh, ow, cout))
            else:
                if o["depth_multiplier"] != 1 or wt.shape[3] != c:
                    raise UnsupportedModelError(f"{_where(op, m)}: depth multiplier {o['depth_multiplier']}; "
                                                "the runtime's depthwise convolution has multiplier 1")
                node = Node(kind="depthwise_conv2d", weight=np.ascontiguousarray(wt[0].transpose(2, 0, 1)), **common)
                node.weight_scale = grid(ins[1], c, 3)
                emit(node, out, (oh, ow, c))
        elif kind == "SPACE_TO_BATCH_ND":
            # Expect SPACE_TO_BATCH_ND -> DEPTHWISE_CONV_2D (VALID, stride 1) -> BATCH_TO_SPACE_ND.
            dw = next((p for p in ops if p.index > op.index and p.inputs and p.inputs[0] == out), None)
            b2s = next((p for p in ops if dw is not None and p.index > dw.index and p.inputs and
                        p.inputs[0] == dw.outputs[0]), None) if dw else None
            if (dw is None or b2s is None or dw.opcode != "DEPTHWISE_CONV_2D" or b2s.opcode != "BATCH_TO_SPACE_ND"
                    or dw.options["padding"] != "VALID" or (dw.options["stride_h"], dw.options["stride_w"]) != (1, 1)
                    or readers.get(out, 0) != 1 or readers.get(dw.outputs[0], 0) != 1):
                raise UnsupportedModelError(f"{_where(op, m)}: not the SPACE_TO_BATCH_ND -> DEPTHWISE_CONV_2D (VALID) "
                                            "-> BATCH_TO_SPACE_ND pattern of a dilated depthwise convolution")
            block = [int(v) for v in const(ins[1], op)]
            pads = const(ins[2], op).astype(np.int64)
            crops = const(b2s.inputs[2], b2s).astype(np.int64)
            if [int(v) for v in const(b2s.inputs[1], b2s)] != block or crops[0][0] or crops[1][0]:
                raise UnsupportedModelError(f"{_where(b2s, m)}: block or crops do not match {_where(op, m)}")
            x = act_in(ins[0], op)
            h, w, c = shapes[x]
            wt = const(dw.inputs[1], dw)
            kh, kw = wt.shape[1], wt.shape[2]
            base = [(int(pads[a][0]), int(pads[a][1] - crops[a][1])) for a in range(2)]
            oh = h + base[0][0] + base[0][1] - (kh - 1) * block[0]
            ow = w + base[1][0] + base[1][1] - (kw - 1) * block[1]
            if (oh, ow) != (h, w) or wt.shape[3] != c or dw.options["depth_multiplier"] != 1:
                raise UnsupportedModelError(f"{_where(dw, m)}: dilated depthwise that changes the size "
                                            f"{h}x{w} -> {oh}x{ow} or the channels")
            b = const(dw.inputs[2], dw) if len(dw.inputs) > 2 and dw.inputs[2] >= 0 else np.zeros(c, np.float32)
            out2 = b2s.outputs[0]
            node = Node(name=_tname(m, out2), kind="depthwise_conv2d", inputs=[_tname(m, x)], output=_tname(m, out2),
                        weight=np.ascontiguousarray(wt[0].transpose(2, 0, 1)), bias=b.astype(np.float32),
                        kernel=(kh, kw), stride=(1, 1), dilation=tuple(block),
                        pads=(base[0][0], base[1][0], base[0][1], base[1][1]), act_range=_act(dw, m))
            node.weight_scale = grid(dw.inputs[1], c, 3)
            emit(node, out2, (h, w, c))
            skip.update((dw.index, b2s.index))
        elif kind in ("MUL", "ADD"):
            a_const = [m.tensors[t].data is not None or t in consts for t in ins]
            if not any(a_const):
                if kind == "MUL":
                    raise UnsupportedModelError(f"{_where(op, m)}: product of two activations")
                xa, xb = act_in(ins[0], op), act_in(ins[1], op)
                if shapes[xa] != shapes[xb]:
                    raise UnsupportedModelError(f"{_where(op, m)}: ADD of shapes {shapes[xa]} and {shapes[xb]}")
                emit(Node(name=_tname(m, out), kind="add", inputs=[_tname(m, xa), _tname(m, xb)],
                          output=_tname(m, out), act_range=_act(op, m)), out, shapes[xa])
            else:
                xi = 1 if a_const[0] else 0
                x = act_in(ins[xi], op)
                v = const(ins[1 - xi], op).astype(np.float32)
                c = shapes[x][2]
                if v.size not in (1, c):
                    raise UnsupportedModelError(f"{_where(op, m)}: constant of {v.size} values over {c} channels")
                v = np.broadcast_to(v.reshape(-1), (c,)).astype(np.float32)
                # A per-channel scale / shift: a batchnorm node that passes.finish folds into the
                # convolution before it (or refuses with the node's name).
                node = Node(name=_tname(m, out), kind="batchnorm", inputs=[_tname(m, x)], output=_tname(m, out),
                            bn_scale=v if kind == "MUL" else np.ones(c, np.float32),
                            bn_shift=np.zeros(c, np.float32) if kind == "MUL" else v)
                emit(node, out, shapes[x])
                lo_hi = _act(op, m)
                if lo_hi != (-INF, INF):
                    clamp_out = out
                    node.output = _tname(m, out) + ":pre_act"
                    emit(Node(name=_tname(m, out) + ":act", kind="clamp", inputs=[node.output],
                              output=_tname(m, clamp_out), act_range=lo_hi), out, shapes[x])
        elif kind == "AVERAGE_POOL_2D":
            x = act_in(ins[0], op)
            h, w, c = shapes[x]
            fh, fw = o["filter_h"], o["filter_w"]
            if smap:
                fh, fw = smap.dim(fh, 0), smap.dim(fw, 1)
            if o["padding"] != "VALID" and (fh, fw) != (1, 1):
                raise UnsupportedModelError(f"{_where(op, m)}: SAME average pooling not supported")
            stride = (o["stride_h"], o["stride_w"])
            oh, ow = (h - fh) // stride[0] + 1, (w - fw) // stride[1] + 1
            emit(Node(name=_tname(m, out), kind="avg_pool", inputs=[_tname(m, x)], output=_tname(m, out),
                      kernel=(fh, fw), stride=stride), out, (oh, ow, c))
            if _act(op, m) != (-INF, INF):
                raise UnsupportedModelError(f"{_where(op, m)}: fused activation on average pooling")
        elif kind == "RESIZE_BILINEAR":
            x = act_in(ins[0], op)
            h, w, c = shapes[x]
            th, tw = [int(v) for v in const(ins[1], op)]
            if smap:
                th, tw = smap.dim(th, 0), smap.dim(tw, 1)
            if not o["align_corners"] or o["half_pixel_centers"]:
                raise UnsupportedModelError(f"{_where(op, m)}: only align_corners resizing is supported")
            if (th, tw) == (h, w):
                alias[out] = x
                continue
            if op.index == last_index and out == m.outputs[0] and (th, tw) == hw and not keep_final_resize:
                alias[out] = x
                continue
            emit(Node(name=_tname(m, out), kind="resize_bilinear", inputs=[_tname(m, x)], output=_tname(m, out),
                      size=(th, tw)), out, (th, tw, c))
        elif kind == "CONCATENATION":
            if o["axis"] not in (3, -1):
                raise UnsupportedModelError(f"{_where(op, m)}: concatenation along axis {o['axis']}; only channels")
            xs = [act_in(t, op) for t in ins]
            if len({shapes[t][:2] for t in xs}) != 1:
                raise UnsupportedModelError(f"{_where(op, m)}: inputs differ in size")
            h, w, _ = shapes[xs[0]]
            emit(Node(name=_tname(m, out), kind="concat", inputs=[_tname(m, t) for t in xs], output=_tname(m, out)),
                 out, (h, w, sum(shapes[t][2] for t in xs)))
            if _act(op, m) != (-INF, INF):
                raise UnsupportedModelError(f"{_where(op, m)}: fused activation on concatenation")
        else:
            raise UnsupportedModelError(f"{_where(op, m)}: operator not supported by the int8 runtime")

    out_t = alias.get(m.outputs[0], m.outputs[0])
    if out_t not in shapes:
        raise UnsupportedModelError(f"graph output {m.describe(m.outputs[0])} is never computed")
    nclass = shapes[out_t][2]
    if class_names is not None and len(class_names) != nclass:
        raise UnsupportedModelError(f"{len(class_names)} class names for {nclass} output channels")
    g = Graph(name=name or "tflite", input=_tname(m, m.inputs[0]), input_shape=(hw[0], hw[1], cin),
              output=_tname(m, out_t), nodes=nodes, mean=mean, scale=scale,
              class_names=list(class_names) if class_names else [f"class{i}" for i in range(nclass)])
    return finish(g, {n.name: n.name for n in nodes})


def allowed_sizes(lo=129, hi=1025):
    """Input sides the alignment allows (k * output stride + 1)."""
    return list(range(lo + (-(lo - 1)) % OUTPUT_STRIDE, hi + 1, OUTPUT_STRIDE))
