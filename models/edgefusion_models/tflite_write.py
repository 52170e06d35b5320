"""A small writer of TensorFlow Lite model files (FlatBuffers), the reverse of tflite.py: enough of the
public schema (tensorflow/lite/schema/schema.fbs) to write tiny int8 models whose every part the
reader decodes (operator codes, builtin and custom; tensors with shapes, types, buffers, names and
per-tensor or per-axis quantisation; operators with their builtin options; buffers; a description).

Its use is the seed corpus of the reader's fuzzer (tests/fuzz/tflite/fuzz_tflite.py): files our own
code writes, never pieces of a downloaded model.

    python3 -m edgefusion_models.tflite_write --seeds DIR     writes DIR/*.tflite

Layout: objects are laid out front to back, each parent before its children, so every uoffset is
positive as FlatBuffers requires; a table's vtable sits just before it (a positive soffset). Tables,
vectors and strings are 4-byte aligned, buffer data 16-byte aligned.
"""
import argparse
import os
import struct
from typing import Dict, List, Optional, Tuple

import numpy as np


class Table:
    """A table to write: field index -> (kind, value). Kinds: a struct format ("b", "i", "I", "f",
    "B") for scalars, "table", "tables", "string", or "vector:<fmt>" for a vector of scalars."""

    def __init__(self, fields: Optional[Dict[int, Tuple[str, object]]] = None):
        self.fields = dict(fields or {})


class _Out:
    def __init__(self):
        self.b = bytearray()
        self.todo: List[Tuple[int, object, str]] = []  # (field position, child, kind) to place

    def align(self, n: int):
        while len(self.b) % n:
            self.b.append(0)

    def table(self, t: Table) -> int:
        """Writes vtable + table; returns the table's position. Children are queued."""
        scalars = {i: v for i, v in t.fields.items()}
        n_fields = (max(scalars) + 1) if scalars else 0
        # The table: soffset, then each field (scalars by value, offsets as placeholders).
        layout = []  # (index, fmt)
        size = 4
        for i in sorted(scalars):
            kind = scalars[i][0]
            fmt = kind if len(kind) == 1 else "I"
            sz = struct.calcsize("<" + fmt)
            while size % sz:
                size += 1
            layout.append((i, fmt, size))
            size += sz
        while size % 4:
            size += 1
        vt_bytes = 4 + 2 * n_fields
        self.align(4)
        # vtable first, padded so the table starts 4-byte aligned.
        vt = len(self.b)
        offsets = [0] * n_fields
        for i, _, off in layout:
            offsets[i] = off
        self.b += struct.pack("<HH", vt_bytes, size) + b"".join(struct.pack("<H", o) for o in offsets)
        self.align(4)
        pos = len(self.b)
        self.b += bytes(size)
        struct.pack_into("<i", self.b, pos, pos - vt)
        for i, fmt, off in layout:
            kind, value = scalars[i]
            if len(kind) == 1:
                struct.pack_into("<" + fmt, self.b, pos + off, value)
            else:
                self.todo.append((pos + off, value, kind))
        return pos

    def place(self, at: int, value, kind: str):
        """Writes the child of the offset field at `at` and points the field at it."""
        if kind == "table":
            target = self.table(value)
        elif kind == "string":
            self.align(4)
            target = len(self.b)
            data = value.encode("utf-8")
            self.b += struct.pack("<I", len(data)) + data + b"\0"
        elif kind == "tables":
            self.align(4)
            target = len(self.b)
            self.b += struct.pack("<I", len(value)) + bytes(4 * len(value))
            for k, child in enumerate(value):
                self.todo.append((target + 4 + 4 * k, child, "table"))
        elif kind.startswith("vector:"):
            fmt = kind.split(":", 1)[1]
            self.align(16 if fmt == "B" else 4)
            # The count sits right before the elements: align the elements, not the count.
            if fmt == "B":
                self.b += bytes(12)
            target = len(self.b)
            arr = list(value)
            self.b += struct.pack("<I", len(arr)) + struct.pack("<%d%s" % (len(arr), fmt), *arr)
        else:
            raise ValueError(kind)
        struct.pack_into("<I", self.b, at, target - at)

    def finish(self, root: Table) -> bytes:
        self.b += bytes(8)  # root offset, file identifier
        self.b[4:8] = b"TFL3"
        pos = self.table(root)
        struct.pack_into("<I", self.b, 0, pos)
        while self.todo:
            at, value, kind = self.todo.pop(0)
            self.place(at, value, kind)
        return bytes(self.b)


def write(root: Table) -> bytes:
    """The FlatBuffer of a Model table (file identifier TFL3)."""
    return _Out().finish(root)


# ---- Model building ----

TYPE_CODES = {np.float32: 0, np.int32: 2, np.uint8: 3, np.int64: 4, np.int8: 9}
OPTION_TYPES = {"CONV_2D": 1, "DEPTHWISE_CONV_2D": 2, "AVERAGE_POOL_2D": 5, "MAX_POOL_2D": 5, "SOFTMAX": 9,
                "CONCATENATION": 10, "ADD": 11, "RESIZE_BILINEAR": 15}
CODES = {"ADD": 0, "AVERAGE_POOL_2D": 1, "CONCATENATION": 2, "CONV_2D": 3, "DEPTHWISE_CONV_2D": 4,
         "DEQUANTIZE": 6, "MAX_POOL_2D": 17, "RELU6": 21, "RESIZE_BILINEAR": 23, "SOFTMAX": 25, "MEAN": 40,
         "HARD_SWISH": 126}


class ModelBuilder:
    """Tensors, buffers and operators of one subgraph, then write()."""

    def __init__(self, description: str):
        self.description = description
        self.tensors: List[Table] = []
        self.buffers: List[Table] = [Table()]  # buffer 0: the empty one activations point at
        self.codes: List[Tuple[str, object]] = []
        self.ops: List[Table] = []

    def tensor(self, name, shape, dtype=np.int8, scale=None, zero_point=None, qdim=0, data=None) -> int:
        f = {0: ("vector:i", list(shape)), 1: ("b", TYPE_CODES[dtype]), 3: ("string", name)}
        if data is not None:
            raw = np.asarray(data, dtype=np.dtype(dtype).newbyteorder("<")).tobytes()
            self.buffers.append(Table({0: ("vector:B", raw)}))
            f[2] = ("I", len(self.buffers) - 1)
        if scale is not None:
            q = {2: ("vector:f", [float(s) for s in np.atleast_1d(scale)]),
                 3: ("vector:q", [int(z) for z in np.atleast_1d(zero_point if zero_point is not None else 0)])}
            if qdim:
                q[6] = ("i", qdim)
            f[4] = ("table", Table(q))
        self.tensors.append(Table(f))
        return len(self.tensors) - 1

    def _code(self, op: str) -> int:
        key = ("custom", op) if op.startswith("CUSTOM:") else ("builtin", op)
        if key not in self.codes:
            self.codes.append(key)
        return self.codes.index(key)

    def op(self, op: str, inputs, outputs, options: Optional[Dict[int, Tuple[str, object]]] = None):
        f = {0: ("I", self._code(op)), 1: ("vector:i", list(inputs)), 2: ("vector:i", list(outputs))}
        if options is not None:
            f[3] = ("B", OPTION_TYPES.get(op, 0))
            f[4] = ("table", Table(options))
        self.ops.append(Table(f))

    def write(self, inputs, outputs) -> bytes:
        codes = []
        for kind, op in self.codes:
            if kind == "custom":
                codes.append(Table({0: ("b", 32), 1: ("string", op.split(":", 1)[1]), 3: ("i", 32)}))
            else:
                c = CODES[op]
                codes.append(Table({0: ("b", min(c, 127)), 2: ("i", 1), 3: ("i", c)}))
        sg = Table({0: ("tables", self.tensors), 1: ("vector:i", list(inputs)), 2: ("vector:i", list(outputs)),
                    3: ("tables", self.ops), 4: ("string", "main")})
        root = Table({0: ("I", 3), 1: ("tables", codes), 2: ("tables", [sg]), 3: ("string", self.description),
                      4: ("tables", self.buffers)})
        return write(root)


def tiny_int8_model(seed: int = 1) -> bytes:
    """An 8x8x3 int8 network with every operator the importer reads and every kind of tensor the
    reader decodes: per-axis int8 weights, int32 biases, a float32 constant, a resize size."""
    rng = np.random.default_rng(seed)
    m = ModelBuilder("edgefusion tiny int8 fuzz seed")
    x = m.tensor("input", [1, 8, 8, 3], scale=0.02, zero_point=-3)
    w = m.tensor("conv/weights", [4, 3, 3, 3], scale=rng.uniform(0.002, 0.02, 4), zero_point=[0] * 4, qdim=0,
                 data=rng.integers(-127, 128, (4, 3, 3, 3)))
    b = m.tensor("conv/bias", [4], dtype=np.int32, scale=rng.uniform(1e-5, 1e-4, 4), zero_point=[0] * 4,
                 data=rng.integers(-2000, 2000, 4))
    c = m.tensor("conv", [1, 8, 8, 4], scale=0.05, zero_point=-128)
    m.op("CONV_2D", [x, w, b], [c], {0: ("b", 0), 1: ("i", 1), 2: ("i", 1), 3: ("b", 3), 4: ("i", 1), 5: ("i", 1)})
    dw = m.tensor("dw/weights", [1, 3, 3, 4], scale=rng.uniform(0.002, 0.02, 4), zero_point=[0] * 4, qdim=3,
                  data=rng.integers(-127, 128, (1, 3, 3, 4)))
    db = m.tensor("dw/bias", [4], dtype=np.int32, scale=rng.uniform(1e-5, 1e-4, 4), zero_point=[0] * 4,
                  data=rng.integers(-500, 500, 4))
    d = m.tensor("dw", [1, 4, 4, 4], scale=0.04, zero_point=2)
    m.op("DEPTHWISE_CONV_2D", [c, dw, db], [d],
         {0: ("b", 0), 1: ("i", 2), 2: ("i", 2), 3: ("i", 1), 4: ("b", 1), 5: ("i", 1), 6: ("i", 1)})
    p = m.tensor("pool", [1, 4, 4, 4], scale=0.04, zero_point=2)
    m.op("AVERAGE_POOL_2D", [d], [p], {0: ("b", 0), 1: ("i", 1), 2: ("i", 1), 3: ("i", 3), 4: ("i", 3), 5: ("b", 0)})
    mp = m.tensor("maxpool", [1, 4, 4, 4], scale=0.04, zero_point=2)
    m.op("MAX_POOL_2D", [p], [mp], {0: ("b", 1), 1: ("i", 1), 2: ("i", 1), 3: ("i", 1), 4: ("i", 1), 5: ("b", 0)})
    a = m.tensor("add", [1, 4, 4, 4], scale=0.06, zero_point=0)
    m.op("ADD", [d, mp], [a], {0: ("b", 1)})
    r6 = m.tensor("relu6", [1, 4, 4, 4], scale=0.06, zero_point=0)
    m.op("RELU6", [a], [r6])
    cat = m.tensor("concat", [1, 4, 4, 8], scale=0.06, zero_point=0)
    m.op("CONCATENATION", [a, r6], [cat], {0: ("i", 3), 1: ("b", 0)})
    size = m.tensor("resize/size", [2], dtype=np.int32, data=[8, 8])
    up = m.tensor("resize", [1, 8, 8, 8], scale=0.06, zero_point=0)
    m.op("RESIZE_BILINEAR", [cat, size], [up], {2: ("B", 1), 3: ("B", 0)})
    hs = m.tensor("hard_swish", [1, 8, 8, 8], scale=0.06, zero_point=0)
    m.op("HARD_SWISH", [up], [hs])
    sm = m.tensor("softmax", [1, 8, 8, 8], scale=1.0 / 256, zero_point=-128)
    m.op("SOFTMAX", [hs], [sm], {0: ("f", 1.0)})
    mean_w = m.tensor("float/const", [2, 2], dtype=np.float32, data=[[0.5, -1.0], [2.0, 0.25]])
    deq = m.tensor("dequantized", [1, 8, 8, 8], dtype=np.float32)
    m.op("DEQUANTIZE", [sm], [deq])
    cust = m.tensor("custom_out", [1, 8, 8, 8], dtype=np.float32)
    m.op("CUSTOM:EdgeFusionNoop", [deq, mean_w, -1], [cust])
    return m.write([x], [cust])


def tiny_float_model() -> bytes:
    """A float32 network of two operators: float weights, no quantisation at all."""
    m = ModelBuilder("edgefusion tiny float fuzz seed")
    x = m.tensor("input", [1, 4, 4, 3], dtype=np.float32)
    w = m.tensor("w", [2, 1, 1, 3], dtype=np.float32, data=np.arange(6, dtype=np.float32).reshape(2, 1, 1, 3) / 10)
    y = m.tensor("y", [1, 4, 4, 2], dtype=np.float32)
    m.op("CONV_2D", [x, w, -1], [y], {0: ("b", 1), 1: ("i", 1), 2: ("i", 1), 3: ("b", 0)})
    z = m.tensor("z", [1, 4, 4, 2], dtype=np.float32)
    m.op("SOFTMAX", [y], [z], {0: ("f", 0.5)})
    return m.write([x], [z])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", required=True, help="folder for the seed files")
    args = ap.parse_args()
    os.makedirs(args.seeds, exist_ok=True)
    for name, data in (("tiny_int8.tflite", tiny_int8_model()), ("tiny_float.tflite", tiny_float_model())):
        with open(os.path.join(args.seeds, name), "wb") as f:
            f.write(data)


if __name__ == "__main__":
    main()
