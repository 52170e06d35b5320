"""Graph rewrites shared by the PyTorch and ONNX importers: build convolution nodes from the
framework's OIHW weights, fold batch normalisation into the preceding convolution, fuse ReLU / ReLU6 /
clamp into the producing layer's output range, and finish the graph with the softmax output stage.
"""
import numpy as np

from .graph import CONV_KINDS, INF, RANGED_KINDS, Graph, Node, UnsupportedModelError, infer_shapes


class GraphBuilder:
    """Collects nodes in execution order while tracking tensor shapes (importers need them for
    size-based upsampling and pool checks) and aliases (identity-like operators)."""

    def __init__(self, input_name, input_shape):
        self.input = input_name
        self.nodes = []
        self.shapes = {input_name: tuple(input_shape)}
        self.alias = {}

    def name(self, tensor):
        return self.alias.get(tensor, tensor)

    def add(self, node):
        self.nodes.append(node)
        g = Graph("partial", self.input, self.shapes[self.input], node.output, self.nodes, [], [])
        self.shapes = infer_shapes(g)


def conv_node(name, x, y, weight_oihw, bias, stride, dilation, pads, groups, op="Conv"):
    """The IR node of a 2-D convolution given OIHW float weights (PyTorch and ONNX layout).

    groups == channels (multiplier 1) is depthwise; 1x1, stride 1, no padding is pointwise;
    groups == 1 otherwise is conv2d. pads = (top, left, bottom, right)."""
    w = np.asarray(weight_oihw, dtype=np.float32)
    cout, cin_g, kh, kw = w.shape
    cin = cin_g * groups
    b = np.zeros(cout, np.float32) if bias is None else np.asarray(bias, dtype=np.float32).reshape(cout)
    common = dict(name=name, inputs=[x], output=y, bias=b, kernel=(kh, kw), stride=tuple(stride),
                  dilation=tuple(dilation), pads=tuple(pads))
    if groups != 1:
        if groups == cin and cout == cin:
            return Node(kind="depthwise_conv2d", weight=w.reshape(cout, kh, kw).copy(), **common)
        raise UnsupportedModelError(
            f"node '{name}' ({op}): grouped convolution with {groups} groups, {cin} input and {cout} output "
            "channels; the runtime has depthwise (groups = input = output channels) and ungrouped convolutions")
    if (kh, kw) == (1, 1) and tuple(stride) == (1, 1) and tuple(pads) == (0, 0, 0, 0):
        return Node(kind="pointwise_conv2d", weight=w.reshape(cout, cin).copy(), **common)
    return Node(kind="conv2d", weight=np.ascontiguousarray(w.transpose(0, 2, 3, 1)), **common)


def _replace_output(g: Graph, node: Node, removed: Node):
    """node takes over removed's output tensor; removed leaves the graph."""
    node.output = removed.output
    g.nodes = [n for n in g.nodes if n is not removed]


def fold_batchnorm(g: Graph):
    """y = conv(x) * s + t  ->  conv with weights * s and bias * s + t (float64, stored float32)."""
    for bn in [n for n in g.nodes if n.kind == "batchnorm"]:
        prod = g.producer().get(bn.inputs[0])
        readers = g.consumers().get(bn.inputs[0], [])
        if (prod is None or prod.kind not in CONV_KINDS or len(readers) != 1 or bn.inputs[0] == g.output or
                prod.act_range != (-INF, INF)):
            raise UnsupportedModelError(
                f"node '{bn.name}' (BatchNormalization): not folded, it must directly follow a convolution "
                "(without activation) whose output nothing else reads; the runtime has no standalone batch norm")
        s = bn.bn_scale.astype(np.float64)
        shape = (-1,) + (1,) * (prod.weight.ndim - 1)
        prod.weight = (prod.weight.astype(np.float64) * s.reshape(shape)).astype(np.float32)
        if prod.weight_scale is not None:  # w = q * scale: folding scales the grid, the integers stay
            prod.weight_scale = (prod.weight_scale.astype(np.float64) * np.abs(s)).astype(np.float32)
        prod.bias = (prod.bias.astype(np.float64) * s + bn.bn_shift.astype(np.float64)).astype(np.float32)
        _replace_output(g, prod, bn)


def fuse_activations(g: Graph):
    """clamp(producer) -> producer with the intersected output range, when the producer can apply a
    range (convolutions, add, clamp) and the clamp is the only reader of its output."""
    changed = True
    while changed:
        changed = False
        for cl in [n for n in g.nodes if n.kind == "clamp"]:
            prod = g.producer().get(cl.inputs[0])
            readers = g.consumers().get(cl.inputs[0], [])
            if prod is None or prod.kind not in RANGED_KINDS or len(readers) != 1 or cl.inputs[0] == g.output:
                continue
            lo = max(prod.act_range[0], cl.act_range[0])
            hi = min(prod.act_range[1], cl.act_range[1])
            prod.act_range = (lo, max(lo, hi))
            _replace_output(g, prod, cl)
            changed = True
            break


def finish(g: Graph, op_names=None):
    """Folds, fuses, appends the softmax output stage when the graph ends in logits, and checks
    that only runtime layer kinds remain. op_names maps node names to the framework's operator type
    for messages."""
    fold_batchnorm(g)
    fuse_activations(g)
    prod = g.producer()
    if prod[g.output].kind != "softmax":
        g.nodes.append(Node(name="softmax", kind="softmax", inputs=[g.output], output="probabilities"))
        g.output = "probabilities"
    for n in g.nodes:
        if n.kind == "softmax" and n.output != g.output:
            op = (op_names or {}).get(n.name, "Softmax")
            raise UnsupportedModelError(
                f"node '{n.name}' ({op}): softmax inside the network; the runtime's softmax is the output stage only")
    infer_shapes(g)
    return g
