"""Float ONNX model -> float IR.

Supported operators: Conv (ungrouped, depthwise with groups == channels, 1x1), BatchNormalization
(folded into the preceding Conv), Relu, Clip (bounds as inputs or attributes), Add, Concat (axis 1),
MaxPool, AveragePool, Resize / Upsample (nearest, or linear with half-pixel centres; one integer
factor 1..16), Softmax over channels (the output stage; appended when the model ends in logits),
Identity, Dropout, Constant. The input is one N x C x H x W float tensor (N = 1 or symbolic) holding
the normalised image; weights and constant operands must be initializers or Constant outputs.
Anything else fails with UnsupportedModelError naming each offending node, its operator and why.
"""
import math

import numpy as np
import onnx
from onnx import numpy_helper

from . import netconst as net  # net.py's constants without torch
from .graph import INF, Graph, Node, UnsupportedModelError, infer_shapes
from .passes import GraphBuilder, conv_node, finish

SUPPORTED = {"Conv", "BatchNormalization", "Relu", "Clip", "Add", "Concat", "MaxPool", "AveragePool", "Resize",
             "Upsample", "Softmax", "Identity", "Dropout", "Constant"}
# Why common operators are missing, for the error message.
WHY_NOT = {
    "Gemm": "fully connected layers are not in the int8 runtime",
    "MatMul": "matrix products are not in the int8 runtime",
    "Sigmoid": "no sigmoid layer in the int8 runtime (it has ReLU, ReLU6 and clamp as output ranges)",
    "Tanh": "no tanh layer in the int8 runtime",
    "HardSigmoid": "no hard sigmoid layer in the int8 runtime",
    "HardSwish": "no hard swish layer in the int8 runtime",
    "LeakyRelu": "no leaky ReLU in the int8 runtime (only ReLU, ReLU6 and clamp ranges)",
    "PRelu": "no PReLU in the int8 runtime (only ReLU, ReLU6 and clamp ranges)",
    "Mul": "no elementwise multiplication in the int8 runtime",
    "Sub": "no subtraction in the int8 runtime",
    "Div": "no division in the int8 runtime",
    "GlobalAveragePool": "no global pooling in the int8 runtime (outputs keep a spatial size)",
    "ConvTranspose": "no transposed convolution in the int8 runtime (use Resize + Conv)",
    "Reshape": "no reshapes in the int8 runtime (tensors stay H x W x C)",
    "Flatten": "no reshapes in the int8 runtime (tensors stay H x W x C)",
    "Transpose": "no transposes in the int8 runtime (tensors stay H x W x C)",
    "Shape": "dynamic shapes: export with fixed input sizes and constant folding",
    "Pad": "no explicit padding layer (padding belongs to Conv / pools)",
    "ArgMax": "the model must end in logits or a softmax over channels",
    "LogSoftmax": "the output stage is a softmax (probabilities), not a log-softmax",
}


def _attrs(node):
    return {a.name: onnx.helper.get_attribute_value(a) for a in node.attribute}


def _s(v):
    return v.decode() if isinstance(v, bytes) else v


class _Importer:
    def __init__(self, model: onnx.ModelProto):
        self.model = model
        self.opset = next((o.version for o in model.opset_import if o.domain in ("", "ai.onnx")), 1)
        self.consts = {i.name: numpy_helper.to_array(i) for i in model.graph.initializer}
        inputs = [i for i in model.graph.input if i.name not in self.consts]
        if len(inputs) != 1:
            raise UnsupportedModelError(f"the model has {len(inputs)} inputs; the runtime takes one image tensor")
        x = inputs[0]
        dims = [d.dim_value if d.HasField("dim_value") else None for d in x.type.tensor_type.shape.dim]
        if len(dims) != 4 or dims[0] not in (None, 1) or any(d is None or d < 1 for d in dims[1:]):
            raise UnsupportedModelError(f"input '{x.name}' has shape {dims}; needs N x C x H x W with fixed C, H, W "
                                        "(N = 1 or symbolic)")
        if x.type.tensor_type.elem_type != onnx.TensorProto.FLOAT:
            raise UnsupportedModelError(f"input '{x.name}' is not float32")
        self.input_name = x.name
        _, c, h, w = dims
        self.b = GraphBuilder(x.name, (h, w, c))

    # -- operands ------------------------------------------------------------------------------
    def const(self, node, i, what, optional=False):
        names = node.input
        if i >= len(names) or names[i] == "":
            if optional:
                return None
            raise self.err(node, f"missing {what}")
        name = names[i]
        if name not in self.consts:
            raise self.err(node, f"{what} '{name}' is not a constant (initializer or Constant)")
        return self.consts[name]

    def tensor(self, node, i):
        name = node.input[i]
        if name in self.consts:
            raise self.err(node, f"operand '{name}' is a constant; the runtime's {node.op_type} takes graph tensors")
        t = self.b.name(name)
        if t not in self.b.shapes:
            raise self.err(node, f"operand '{name}' is not produced by a supported node before this one")
        return t

    def err(self, node, why):
        return UnsupportedModelError(f"ONNX node '{self.node_name(node)}' ({node.op_type}): {why}")

    def node_name(self, node):
        return node.name or f"{node.op_type}_{list(self.model.graph.node).index(node)}"

    def only_first_output_used(self, node, consumers):
        for extra in node.output[1:]:
            if extra and (extra in consumers or extra in {o.name for o in self.model.graph.output}):
                raise self.err(node, f"output '{extra}' is used; only the first output is supported")

    # -- operators -----------------------------------------------------------------------------
    def constant(self, node):
        a = _attrs(node)
        if "value" in a:
            self.consts[node.output[0]] = numpy_helper.to_array(a["value"])
        elif "value_float" in a or "value_floats" in a:
            self.consts[node.output[0]] = np.array(a.get("value_float", a.get("value_floats")), np.float32)
        elif "value_int" in a or "value_ints" in a:
            self.consts[node.output[0]] = np.array(a.get("value_int", a.get("value_ints")), np.int64)
        else:
            raise self.err(node, "only tensor, float and int constants are supported")

    def conv(self, node):
        a = _attrs(node)
        x = self.tensor(node, 0)
        w = self.const(node, 1, "weight")
        if w.ndim != 4:
            raise self.err(node, f"weight of rank {w.ndim}; only 2-D convolutions")
        bias = self.const(node, 2, "bias", optional=True)
        kh, kw = w.shape[2:]
        stride = tuple(a.get("strides", [1, 1]))
        dil = tuple(a.get("dilations", [1, 1]))
        pads = a.get("pads", [0, 0, 0, 0])
        auto = _s(a.get("auto_pad", "NOTSET"))
        if auto in ("SAME_UPPER", "SAME_LOWER"):
            pads = [0, 0, 0, 0]
            for ax, (n, k) in enumerate(zip(self.b.shapes[x][:2], (kh, kw))):
                total = max((math.ceil(n / stride[ax]) - 1) * stride[ax] + dil[ax] * (k - 1) + 1 - n, 0)
                before = total // 2 if auto == "SAME_UPPER" else total - total // 2
                pads[ax], pads[ax + 2] = before, total - before
        elif auto == "VALID":
            pads = [0, 0, 0, 0]
        # ONNX pads: [top, left, bottom, right] (x1_begin, x2_begin, x1_end, x2_end).
        self.b.add(conv_node(self.node_name(node), x, node.output[0], w, bias, stride, dil, tuple(pads),
                             int(a.get("group", 1)), op="Conv"))

    def batchnorm(self, node, consumers):
        a = _attrs(node)
        if a.get("training_mode", 0):
            raise self.err(node, "training_mode=1")
        self.only_first_output_used(node, consumers)
        x = self.tensor(node, 0)
        gamma, beta, mean, var = (self.const(node, i, n).astype(np.float64)
                                  for i, n in ((1, "scale"), (2, "bias"), (3, "mean"), (4, "var")))
        scale = gamma / np.sqrt(var + float(a.get("epsilon", 1e-5)))
        self.b.add(Node(name=self.node_name(node), kind="batchnorm", inputs=[x], output=node.output[0],
                        bn_scale=scale, bn_shift=beta - mean * scale))

    def clip(self, node, lo, hi):
        self.b.add(Node(name=self.node_name(node), kind="clamp", inputs=[self.tensor(node, 0)], output=node.output[0],
                        act_range=(lo, hi)))

    def clip_bounds(self, node):
        if self.opset < 11:
            a = _attrs(node)
            lo, hi = float(a.get("min", -INF)), float(a.get("max", INF))
        else:
            lo_c = self.const(node, 1, "min", optional=True)
            hi_c = self.const(node, 2, "max", optional=True)
            lo = -INF if lo_c is None else float(np.asarray(lo_c).reshape(-1)[0])
            hi = INF if hi_c is None else float(np.asarray(hi_c).reshape(-1)[0])
        # The float32 extremes some exporters write for "no bound".
        return (-INF if lo <= -3.4e38 else lo), (INF if hi >= 3.4e38 else hi)

    def pool(self, node, kind, consumers):
        a = _attrs(node)
        self.only_first_output_used(node, consumers)
        x = self.tensor(node, 0)
        k = tuple(a["kernel_shape"])
        if len(k) != 2:
            raise self.err(node, "only 2-D pooling")
        s = tuple(a.get("strides", [1, 1]))
        pads = tuple(a.get("pads", [0, 0, 0, 0]))
        if _s(a.get("auto_pad", "NOTSET")) not in ("NOTSET", "VALID"):
            raise self.err(node, "auto_pad SAME_* on a pool; give explicit pads")
        if tuple(a.get("dilations", [1, 1])) != (1, 1):
            raise self.err(node, "dilated pooling")
        if kind == "avg_pool" and a.get("count_include_pad", 0) and any(pads):
            raise self.err(node, "count_include_pad=1 with padding; the runtime averages over positions inside the input")
        if a.get("ceil_mode", 0):
            h, w, _ = self.b.shapes[x]
            for n, kk, ss, pa, pb in ((h, k[0], s[0], pads[0], pads[2]), (w, k[1], s[1], pads[1], pads[3])):
                if (n + pa + pb - kk) % ss:
                    raise self.err(node, "ceil_mode=1 changes the output size")
        self.b.add(Node(name=self.node_name(node), kind=kind, inputs=[x], output=node.output[0], kernel=k, stride=s,
                        pads=pads))

    def resize(self, node):
        a = _attrs(node)
        x = self.tensor(node, 0)
        h, w, _ = self.b.shapes[x]
        mode = _s(a.get("mode", "nearest"))
        if node.op_type == "Upsample" or self.opset < 11:
            scales = (self.const(node, 1, "scales") if len(node.input) > 1 else np.array(a.get("scales"), np.float32))
            sizes = None
            coord = "asymmetric"
            nearest_mode = "floor" if node.op_type == "Upsample" else "round_prefer_floor"
        else:
            scales = self.const(node, 2, "scales", optional=True)
            sizes = self.const(node, 3, "sizes", optional=True)
            coord = _s(a.get("coordinate_transformation_mode", "half_pixel"))
            nearest_mode = _s(a.get("nearest_mode", "round_prefer_floor"))
        if scales is not None and np.asarray(scales).size == 4:
            sc = [float(v) for v in np.asarray(scales).reshape(-1)]
            if sc[:2] != [1.0, 1.0] or sc[2] != sc[3] or sc[2] != math.floor(sc[2]):
                raise self.err(node, f"scales {sc}; the runtime upsamples H and W by one integer factor")
            f = int(sc[2])
        elif sizes is not None and np.asarray(sizes).size == 4:
            sz = [int(v) for v in np.asarray(sizes).reshape(-1)]
            if sz[2] % h or sz[3] % w or sz[2] // h != sz[3] // w:
                raise self.err(node, f"sizes {sz} are not one integer multiple of {h}x{w}")
            f = sz[2] // h
        else:
            raise self.err(node, "needs constant scales or sizes")
        if not 1 <= f <= 16:
            raise self.err(node, f"factor {f}; the runtime upsamples by 1..16")
        if mode == "nearest":
            if not _nearest_is_floor(coord, nearest_mode, f):
                raise self.err(node, f"nearest with coordinate_transformation_mode={coord}, nearest_mode={nearest_mode} "
                                     f"does not pick in[o / {f}]")
            m = "nearest"
        elif mode in ("linear", "bilinear"):
            if coord not in ("half_pixel", "pytorch_half_pixel"):
                raise self.err(node, f"linear with coordinate_transformation_mode={coord}; the runtime's bilinear "
                                     "uses half-pixel centres (align_corners=False)")
            m = "bilinear"
        else:
            raise self.err(node, f"mode {mode}; the runtime has nearest and (bi)linear")
        self.b.add(Node(name=self.node_name(node), kind="upsample", inputs=[x], output=node.output[0], factor=f, mode=m))

    def softmax(self, node):
        a = _attrs(node)
        x = self.tensor(node, 0)
        h, w, _ = self.b.shapes[x]
        if self.opset < 13:
            axis = a.get("axis", 1)
            if axis not in (1, -3) or h * w != 1:
                raise self.err(node, f"opset {self.opset} Softmax normalises over everything after axis {axis} "
                                     "(C x H x W together); export with opset >= 13 for a softmax over channels")
        elif a.get("axis", -1) not in (1, -3):
            raise self.err(node, f"softmax over axis {a.get('axis', -1)}; the runtime normalises over channels (axis 1)")
        self.b.add(Node(name=self.node_name(node), kind="softmax", inputs=[x], output=node.output[0]))

    # -- driver --------------------------------------------------------------------------------
    def run(self, mean, scale, class_names, name):
        nodes = list(self.model.graph.node)
        bad = [n for n in nodes if n.op_type not in SUPPORTED or n.domain not in ("", "ai.onnx")]
        if bad:
            raise UnsupportedModelError("unsupported ONNX operators: " + "; ".join(
                f"node '{self.node_name(n)}' ({n.op_type}): "
                + WHY_NOT.get(n.op_type, "not an operator of the int8 runtime (supported: "
                              + ", ".join(sorted(SUPPORTED)) + ")") for n in bad))
        consumers = {t for n in nodes for t in n.input}
        for node in nodes:
            op = node.op_type
            if op == "Constant":
                self.constant(node)
            elif op in ("Identity", "Dropout") and node.input[0] in self.consts:
                self.consts[node.output[0]] = self.consts[node.input[0]]
            elif op in ("Identity", "Dropout"):
                self.only_first_output_used(node, consumers)
                self.b.alias[node.output[0]] = self.tensor(node, 0)
            elif op == "Conv":
                self.conv(node)
            elif op == "BatchNormalization":
                self.batchnorm(node, consumers)
            elif op == "Relu":
                self.clip(node, 0.0, INF)
            elif op == "Clip":
                self.clip(node, *self.clip_bounds(node))
            elif op == "Add":
                self.b.add(Node(name=self.node_name(node), kind="add", inputs=[self.tensor(node, 0), self.tensor(node, 1)],
                                output=node.output[0]))
            elif op == "Concat" and all(t in self.consts for t in node.input):
                # Constant operands (e.g. Resize scales built without constant folding): evaluate.
                self.consts[node.output[0]] = np.concatenate([np.asarray(self.consts[t]).reshape(-1) if
                                                              np.asarray(self.consts[t]).ndim == 0 else self.consts[t]
                                                              for t in node.input], axis=_attrs(node).get("axis", 0))
            elif op == "Concat":
                if _attrs(node).get("axis") not in (1, -3):
                    raise self.err(node, f"axis {_attrs(node).get('axis')}; the runtime concatenates channels (axis 1)")
                self.b.add(Node(name=self.node_name(node), kind="concat",
                                inputs=[self.tensor(node, i) for i in range(len(node.input))], output=node.output[0]))
            elif op == "MaxPool":
                self.pool(node, "max_pool", consumers)
            elif op == "AveragePool":
                self.pool(node, "avg_pool", consumers)
            elif op in ("Resize", "Upsample"):
                self.resize(node)
            elif op == "Softmax":
                self.softmax(node)
        if len(self.model.graph.output) != 1:
            raise UnsupportedModelError(f"the model has {len(self.model.graph.output)} outputs; the runtime has one")
        out = self.b.name(self.model.graph.output[0].name)
        if out not in self.b.shapes or out == self.b.input:
            raise UnsupportedModelError(f"graph output '{self.model.graph.output[0].name}' is not computed by the graph")
        c = self.b.shapes[self.b.input][2]
        if len(mean) != c or len(scale) != c:
            raise UnsupportedModelError(f"the input has {c} channels but the normalisation gives {len(mean)} means "
                                        f"and {len(scale)} scales")
        g = Graph(name=name, input=self.b.input, input_shape=self.b.shapes[self.b.input], output=out, nodes=self.b.nodes,
                  mean=list(mean), scale=list(scale), class_names=list(class_names or []))
        return finish(g)


def _nearest_is_floor(coord, nearest_mode, f):
    """True when ONNX nearest resizing by integer factor f picks in[o // f] for every o."""
    for o in range(4 * f):
        if coord == "asymmetric":
            src = o / f
        elif coord in ("half_pixel", "pytorch_half_pixel"):
            src = (o + 0.5) / f - 0.5
        else:
            return False
        if nearest_mode == "floor":
            i = math.floor(src)
        elif nearest_mode == "ceil":
            i = math.ceil(src)
        elif nearest_mode == "round_prefer_ceil":
            i = math.floor(src + 0.5)
        else:  # round_prefer_floor
            i = math.ceil(src - 0.5)
        if max(i, 0) != o // f:
            return False
    return True


def from_onnx(model_or_path, mean=None, scale=None, class_names=None, name=None):
    """The float IR of an ONNX model (path or ModelProto). mean / scale: the input normalisation
    (default net.py INPUT_MEAN / INPUT_SCALE); class_names: default net.py's when the class count
    matches, else class0, class1, ..."""
    model = onnx.load(model_or_path) if isinstance(model_or_path, str) else model_or_path
    imp = _Importer(model)
    g = imp.run(list(net.INPUT_MEAN if mean is None else mean), list(net.INPUT_SCALE if scale is None else scale),
                [], name or (model.graph.name or "onnx-model"))
    k = infer_shapes(g)[g.output][2]
    if class_names is None:
        class_names = net.CLASS_NAMES if k == len(net.CLASS_NAMES) else [f"class{i}" for i in range(k)]
    if len(class_names) != k:
        raise UnsupportedModelError(f"{len(class_names)} class names for {k} output channels")
    g.class_names = list(class_names)
    return g

