"""EdgeSegNet's input and class constants (net.py), read without importing torch.

The ONNX importer must run where only python3-onnx, python3-numpy and python3-opencv are installed
(`edgefusion model import` checks for exactly those), but net.py imports torch at the top. So the
constants are read from net.py's source: top-level assignments of literals and simple arithmetic
(`1.0 / 127.5`). net.py stays their single definition.
"""
import ast
import operator
import os

NAMES = ("INPUT_HEIGHT", "INPUT_WIDTH", "NUM_CLASSES", "CLASS_NAMES", "INPUT_MEAN", "INPUT_SCALE", "DEPTH_MAX_M")
_BINOPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv}


def _value(node):
    """A literal, list/tuple of them, or +-*/ arithmetic on numbers; ValueError otherwise."""
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, (ast.List, ast.Tuple)):
        return [_value(e) for e in node.elts]
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        return -_value(node.operand)
    if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
        return _BINOPS[type(node.op)](_value(node.left), _value(node.right))
    raise ValueError(f"net.py: line {node.lineno}: not a literal constant")


def read(path=os.path.join(os.path.dirname(os.path.abspath(__file__)), "net.py")):
    with open(path) as f:
        tree = ast.parse(f.read(), path)
    out = {}
    for stmt in tree.body:
        if isinstance(stmt, ast.Assign) and len(stmt.targets) == 1 and isinstance(stmt.targets[0], ast.Name):
            if stmt.targets[0].id in NAMES:
                out[stmt.targets[0].id] = _value(stmt.value)
    missing = [n for n in NAMES if n not in out]
    if missing:
        raise ValueError(f"{path}: constants {missing} not found")
    return out


_C = read()
INPUT_HEIGHT = _C["INPUT_HEIGHT"]
INPUT_WIDTH = _C["INPUT_WIDTH"]
NUM_CLASSES = _C["NUM_CLASSES"]
CLASS_NAMES = _C["CLASS_NAMES"]
INPUT_MEAN = _C["INPUT_MEAN"]
INPUT_SCALE = _C["INPUT_SCALE"]
DEPTH_MAX_M = _C["DEPTH_MAX_M"]
