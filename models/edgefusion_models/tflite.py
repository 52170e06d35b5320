"""A reader of TensorFlow Lite model files (FlatBuffers), written from the public schema
(tensorflow/lite/schema/schema.fbs) without the flatbuffers package.

A FlatBuffer is a tree of tables addressed by little-endian uint32 offsets. A table starts with an
int32 soffset back to its vtable; the vtable is uint16 [vtable bytes, table bytes, field offsets...]
where a field offset of 0 (or one past the vtable's end) means "absent, use the default". Vectors are
a uint32 count followed by the elements; strings are vectors of bytes. Every read here is bounds
checked and raises TFLiteError naming what was being read, so a truncated or hostile file gives a
clear message instead of an IndexError deep inside.

Only what the importer needs is decoded: operator codes, the first subgraph's tensors (shape, type,
buffer, name, quantisation) and operators (inputs, outputs, builtin options), and the buffers.
"""
import math
import struct
from dataclasses import dataclass, field
from typing import Dict, List, Optional

import numpy as np


class TFLiteError(ValueError):
    """A file that is not a TFLite model we can read; the message names the file and the place."""


# BuiltinOperator codes (schema.fbs) the importer knows by name; others are reported by number.
BUILTIN_NAMES = {
    0: "ADD", 1: "AVERAGE_POOL_2D", 2: "CONCATENATION", 3: "CONV_2D", 4: "DEPTHWISE_CONV_2D",
    5: "DEPTH_TO_SPACE", 6: "DEQUANTIZE", 9: "FULLY_CONNECTED", 14: "LOGISTIC", 17: "MAX_POOL_2D",
    18: "MUL", 19: "RELU", 21: "RELU6", 22: "RESHAPE", 23: "RESIZE_BILINEAR", 25: "SOFTMAX",
    28: "TANH", 34: "PAD", 37: "BATCH_TO_SPACE_ND", 38: "SPACE_TO_BATCH_ND", 39: "TRANSPOSE",
    40: "MEAN", 41: "SUB", 42: "DIV", 43: "SQUEEZE", 49: "SPLIT", 56: "ARG_MAX", 97: "RESIZE_NEAREST_NEIGHBOR",
    114: "QUANTIZE", 126: "HARD_SWISH",
}

# TensorType (schema.fbs) -> numpy dtype.
TENSOR_TYPES = {
    0: np.float32, 1: np.float16, 2: np.int32, 3: np.uint8, 4: np.int64, 6: np.bool_, 7: np.int16,
    9: np.int8,
}
TENSOR_TYPE_NAMES = {0: "FLOAT32", 1: "FLOAT16", 2: "INT32", 3: "UINT8", 4: "INT64", 5: "STRING",
                     6: "BOOL", 7: "INT16", 8: "COMPLEX64", 9: "INT8"}

# ActivationFunctionType.
ACTIVATIONS = {0: "NONE", 1: "RELU", 2: "RELU_N1_TO_1", 3: "RELU6", 4: "TANH", 5: "SIGN_BIT"}
PADDINGS = {0: "SAME", 1: "VALID"}


class _Buf:
    """Bounds-checked little-endian reads of the file's bytes."""

    def __init__(self, data: bytes, name: str):
        self.data = data
        self.name = name

    def _need(self, pos: int, size: int, what: str):
        if pos < 0 or pos + size > len(self.data):
            raise TFLiteError(f"{self.name}: {what}: bytes {pos}..{pos + size} outside the file "
                              f"({len(self.data)} bytes)")

    def u8(self, pos, what):
        self._need(pos, 1, what)
        return self.data[pos]

    def u16(self, pos, what):
        self._need(pos, 2, what)
        return struct.unpack_from("<H", self.data, pos)[0]

    def i32(self, pos, what):
        self._need(pos, 4, what)
        return struct.unpack_from("<i", self.data, pos)[0]

    def u32(self, pos, what):
        self._need(pos, 4, what)
        return struct.unpack_from("<I", self.data, pos)[0]


class _Table:
    """One FlatBuffers table at `pos`."""

    def __init__(self, buf: _Buf, pos: int, what: str):
        self.buf, self.pos, self.what = buf, pos, what
        vt = pos - buf.i32(pos, what + " (vtable offset)")
        self.vt = vt
        self.vt_bytes = buf.u16(vt, what + " (vtable size)")
        if self.vt_bytes < 4 or self.vt_bytes % 2:
            raise TFLiteError(f"{buf.name}: {what}: bad vtable size {self.vt_bytes}")
        buf._need(vt, self.vt_bytes, what + " (vtable)")

    def _field(self, index: int) -> int:
        """Byte position of field `index`, or 0 when absent."""
        entry = 4 + 2 * index
        if entry + 2 > self.vt_bytes:
            return 0
        off = self.buf.u16(self.vt + entry, self.what)
        return self.pos + off if off else 0

    def scalar(self, index: int, fmt: str, default):
        p = self._field(index)
        if not p:
            return default
        size = struct.calcsize("<" + fmt)
        self.buf._need(p, size, f"{self.what} field {index}")
        return struct.unpack_from("<" + fmt, self.buf.data, p)[0]

    def _indirect(self, index: int) -> int:
        p = self._field(index)
        if not p:
            return 0
        return p + self.buf.u32(p, f"{self.what} field {index} (offset)")

    def table(self, index: int, what: str) -> Optional["_Table"]:
        p = self._indirect(index)
        return _Table(self.buf, p, what) if p else None

    def _vector(self, index: int, elem_size: int, what: str):
        p = self._indirect(index)
        if not p:
            return 0, 0
        n = self.buf.u32(p, what + " (count)")
        self.buf._need(p + 4, n * elem_size, what)
        return p + 4, n

    def string(self, index: int, what: str) -> str:
        start, n = self._vector(index, 1, what)
        return self.buf.data[start:start + n].decode("utf-8", "replace") if start else ""

    def array(self, index: int, dtype, what: str) -> np.ndarray:
        dt = np.dtype(dtype).newbyteorder("<")
        start, n = self._vector(index, dt.itemsize, what)
        if not start:
            return np.zeros(0, dtype=dtype)
        return np.frombuffer(self.buf.data, dtype=dt, count=n, offset=start).astype(dtype)

    def tables(self, index: int, what: str) -> List["_Table"]:
        start, n = self._vector(index, 4, what)
        return [_Table(self.buf, start + 4 * i + self.buf.u32(start + 4 * i, what), f"{what}[{i}]")
                for i in range(n)]


@dataclass
class Tensor:
    index: int
    name: str
    shape: List[int]
    dtype: type
    type_name: str
    buffer: int
    scale: np.ndarray          # float32, empty when not quantised
    zero_point: np.ndarray     # int64
    quantized_dimension: int
    data: Optional[np.ndarray] = None  # constant contents (shaped), None for activations


@dataclass
class Operator:
    index: int
    opcode: str                 # builtin name, "BUILTIN_<n>" or "CUSTOM:<name>"
    inputs: List[int]           # tensor indices, -1 for an omitted optional input
    outputs: List[int]
    options: Dict[str, object] = field(default_factory=dict)


@dataclass
class Model:
    path: str
    version: int
    description: str
    tensors: List[Tensor]
    operators: List[Operator]
    inputs: List[int]
    outputs: List[int]

    def describe(self, t: int) -> str:
        """'name' [shape] of tensor t, for messages."""
        if t < 0:
            return "(none)"
        x = self.tensors[t]
        return f"'{x.name}' {x.shape}"


def _options(op: str, t: Optional[_Table]) -> Dict[str, object]:
    """The builtin options of the operators the importer reads (schema.fbs field order)."""
    if t is None:
        return {}
    act = lambda i: ACTIVATIONS.get(t.scalar(i, "b", 0), "UNKNOWN")  # noqa: E731
    if op == "CONV_2D":
        return {"padding": PADDINGS.get(t.scalar(0, "b", 0), "UNKNOWN"), "stride_w": t.scalar(1, "i", 0),
                "stride_h": t.scalar(2, "i", 0), "activation": act(3),
                "dilation_w": t.scalar(4, "i", 1), "dilation_h": t.scalar(5, "i", 1)}
    if op == "DEPTHWISE_CONV_2D":
        return {"padding": PADDINGS.get(t.scalar(0, "b", 0), "UNKNOWN"), "stride_w": t.scalar(1, "i", 0),
                "stride_h": t.scalar(2, "i", 0), "depth_multiplier": t.scalar(3, "i", 0),
                "activation": act(4), "dilation_w": t.scalar(5, "i", 1), "dilation_h": t.scalar(6, "i", 1)}
    if op in ("AVERAGE_POOL_2D", "MAX_POOL_2D"):
        return {"padding": PADDINGS.get(t.scalar(0, "b", 0), "UNKNOWN"), "stride_w": t.scalar(1, "i", 0),
                "stride_h": t.scalar(2, "i", 0), "filter_w": t.scalar(3, "i", 0),
                "filter_h": t.scalar(4, "i", 0), "activation": act(5)}
    if op in ("ADD", "MUL", "SUB", "DIV"):
        return {"activation": act(0)}
    if op == "CONCATENATION":
        return {"axis": t.scalar(0, "i", 0), "activation": act(1)}
    if op == "RESIZE_BILINEAR":
        return {"align_corners": bool(t.scalar(2, "B", 0)), "half_pixel_centers": bool(t.scalar(3, "B", 0))}
    if op == "SOFTMAX":
        return {"beta": t.scalar(0, "f", 0.0)}
    return {}


def read(path: str) -> Model:
    """Reads a .tflite file: its first subgraph, constants as numpy arrays in the file's layout."""
    with open(path, "rb") as f:
        data = f.read()
    return parse(data, path)


def parse(data: bytes, name: str) -> Model:
    buf = _Buf(data, name)
    if len(data) < 8:
        raise TFLiteError(f"{name}: {len(data)} bytes, too short for a TFLite file")
    if data[4:8] != b"TFL3":
        raise TFLiteError(f"{name}: file identifier {data[4:8]!r}, expected b'TFL3' (not a TFLite model)")
    root = _Table(buf, buf.u32(0, "root offset"), "Model")
    version = root.scalar(0, "I", 0)
    codes = []
    for i, oc in enumerate(root.tables(1, "Model.operator_codes")):
        # builtin_code (field 3, int32) supersedes the deprecated byte (field 0) for codes >= 127.
        code = max(oc.scalar(0, "b", 0), oc.scalar(3, "i", 0))
        if code == 32:
            codes.append("CUSTOM:" + oc.string(1, f"operator_codes[{i}].custom_code"))
        else:
            codes.append(BUILTIN_NAMES.get(code, f"BUILTIN_{code}"))
    buffers = [b.array(0, np.uint8, f"buffers[{i}].data") for i, b in enumerate(root.tables(4, "Model.buffers"))]
    subgraphs = root.tables(2, "Model.subgraphs")
    if not subgraphs:
        raise TFLiteError(f"{name}: no subgraph")
    sg = subgraphs[0]
    tensors = []
    for i, t in enumerate(sg.tables(0, "SubGraph.tensors")):
        what = f"tensors[{i}]"
        type_code = t.scalar(1, "b", 0)
        q = t.table(4, what + ".quantization")
        scale = q.array(2, np.float32, what + ".scale") if q else np.zeros(0, np.float32)
        zp = q.array(3, np.int64, what + ".zero_point") if q else np.zeros(0, np.int64)
        qdim = q.scalar(6, "i", 0) if q else 0
        tensor = Tensor(index=i, name=t.string(3, what + ".name"), shape=[int(s) for s in t.array(0, np.int32, what + ".shape")],
                        dtype=TENSOR_TYPES.get(type_code), type_name=TENSOR_TYPE_NAMES.get(type_code, str(type_code)),
                        buffer=t.scalar(2, "I", 0), scale=scale, zero_point=zp, quantized_dimension=qdim)
        if scale.size > 1:
            # Per-axis quantisation: one scale per index of the quantised dimension (schema.fbs).
            if not 0 <= qdim < len(tensor.shape) or tensor.shape[qdim] != scale.size:
                raise TFLiteError(f"{name}: tensor {i} '{tensor.name}': {scale.size} per-axis scales along "
                                  f"dimension {qdim} of shape {tensor.shape}")
            if zp.size not in (0, 1, scale.size):
                raise TFLiteError(f"{name}: tensor {i} '{tensor.name}': {zp.size} zero points for "
                                  f"{scale.size} per-axis scales")
        if tensor.buffer >= len(buffers) and tensor.buffer != 0:
            raise TFLiteError(f"{name}: tensor {i} '{tensor.name}': buffer {tensor.buffer} out of range "
                              f"({len(buffers)} buffers)")
        raw = buffers[tensor.buffer] if tensor.buffer < len(buffers) else np.zeros(0, np.uint8)
        if raw.size:
            if tensor.dtype is None:
                raise TFLiteError(f"{name}: tensor {i} '{tensor.name}': constant of type {tensor.type_name} not supported")
            # A constant's shape is known: no dimension below 0 (-1 means "dynamic" in activations
            # only). The count in Python integers (numpy's int64 product wraps for huge shapes).
            if any(d < 0 for d in tensor.shape):
                raise TFLiteError(f"{name}: tensor {i} '{tensor.name}': constant of shape {tensor.shape} "
                                  f"has a negative dimension")
            count = math.prod(tensor.shape)
            itemsize = np.dtype(tensor.dtype).itemsize
            if raw.size != count * itemsize:
                raise TFLiteError(f"{name}: tensor {i} '{tensor.name}': buffer of {raw.size} bytes for shape "
                                  f"{tensor.shape} of {tensor.type_name} ({count * itemsize} bytes)")
            tensor.data = np.frombuffer(raw.tobytes(), dtype=np.dtype(tensor.dtype).newbyteorder("<")).astype(
                tensor.dtype).reshape(tensor.shape)
        tensors.append(tensor)
    operators = []
    for i, o in enumerate(sg.tables(3, "SubGraph.operators")):
        what = f"operators[{i}]"
        code_index = o.scalar(0, "I", 0)
        if code_index >= len(codes):
            raise TFLiteError(f"{name}: operator {i}: opcode index {code_index} out of range ({len(codes)} codes)")
        op = codes[code_index]
        ins = [int(x) for x in o.array(1, np.int32, what + ".inputs")]
        outs = [int(x) for x in o.array(2, np.int32, what + ".outputs")]
        for t in ins + outs:
            if t >= len(tensors) or t < -1:
                raise TFLiteError(f"{name}: operator {i} ({op}): tensor {t} out of range ({len(tensors)} tensors)")
        operators.append(Operator(index=i, opcode=op, inputs=ins, outputs=outs,
                                  options=_options(op, o.table(4, what + ".builtin_options"))))
    ins = [int(x) for x in sg.array(1, np.int32, "SubGraph.inputs")]
    outs = [int(x) for x in sg.array(2, np.int32, "SubGraph.outputs")]
    return Model(path=name, version=version, description=root.string(3, "Model.description"),
                 tensors=tensors, operators=operators, inputs=ins, outputs=outs)


def dequantize(t: Tensor) -> np.ndarray:
    """The float value of a constant: float as is, int8/uint8 through its (per-axis) scale and zero point."""
    if t.data is None:
        raise TFLiteError(f"tensor {t.index} '{t.name}' has no constant data")
    if t.data.dtype in (np.float32, np.float16):
        return t.data.astype(np.float32)
    if t.scale.size == 0:
        return t.data.astype(np.float32)
    shape = [1] * t.data.ndim
    if t.scale.size > 1:
        shape[t.quantized_dimension] = t.scale.size
    s = t.scale.reshape(shape).astype(np.float64)
    z = (t.zero_point.reshape(shape) if t.zero_point.size == t.scale.size else np.zeros(shape)).astype(np.float64)
    return ((t.data.astype(np.float64) - z) * s).astype(np.float32)
