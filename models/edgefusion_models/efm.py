""".efm writer and reader (docs/model_format.md, section 2): version 1 (META, TENS, LAYR, WGHT) for
a model without a class map, version 2 (the same plus CMAP) for one with.

The writer lays the bytes out exactly as ef::nn::serialize_model_unchecked does (weight blocks padded
to 4-byte offsets before each block, nothing after the last), so a model written here and one
re-serialised by the C++ runtime are the same bytes. The reader checks the header, CRC and section
framing and returns a QModel; the full semantic checks are qmodel.validate().
"""
import struct
import zlib

import numpy as np

from .qmodel import (CONV_TYPES, Activation, DType, LayerType, QLayer, QModel, QTensor, UpsampleMode,
                     validate, weights_per_channel)

MAGIC = b"EFM1"
VERSION = 1              # four sections
VERSION_CLASS_MAP = 2    # the four and CMAP (QModel.class_map / target_class_names)
HEADER_BYTES = 16
MAX_PAYLOAD_BYTES = 256 << 20
SECTION_TAGS = (b"META", b"TENS", b"LAYR", b"WGHT")
CMAP_TAG = b"CMAP"


class EfmFormatError(ValueError):
    pass


def _f32(v):
    return struct.pack("<f", float(np.float32(v)))


def _meta(m: QModel):
    name = m.name.encode()
    out = [struct.pack("<H", len(name)), name,
           struct.pack("<III", m.input_tensor, m.output_tensor, len(m.input_mean))]
    out += [_f32(v) for v in m.input_mean] + [_f32(v) for v in m.input_scale]
    out.append(struct.pack("<I", len(m.class_names)))
    for cn in m.class_names:
        b = cn.encode()
        out += [struct.pack("<B", len(b)), b]
    return b"".join(out)


def _names(names):
    out = [struct.pack("<I", len(names))]
    for cn in names:
        b = cn.encode()
        out += [struct.pack("<B", len(b)), b]
    return b"".join(out)


def _cmap(m: QModel):
    """u32 targets, target names (u8 length, bytes), u32 entries, u8 target class per output channel."""
    return (_names(m.target_class_names) + struct.pack("<I", len(m.class_map)) +
            bytes(int(k) for k in m.class_map))


def _tens(m: QModel):
    out = [struct.pack("<I", len(m.tensors))]
    for t in m.tensors:
        out.append(struct.pack("<B3xIIII", int(t.dtype), t.n, t.h, t.w, t.c) + _f32(t.scale) +
                   struct.pack("<i", int(t.zero_point)))
    return b"".join(out)


def _weight_block(l: QLayer):
    return (np.asarray(l.weight_scales, dtype="<f4").tobytes() + np.asarray(l.bias, dtype="<i4").tobytes() +
            np.asarray(l.weights, dtype=np.int8).reshape(-1).tobytes())


def _layr_wght(m: QModel):
    layr = [struct.pack("<I", len(m.layers))]
    wght = bytearray()
    for l in m.layers:
        layr.append(struct.pack("<BBBBI", int(l.type), int(l.act), int(l.mode), len(l.inputs), l.output))
        layr.append(struct.pack(f"<{len(l.inputs)}I", *l.inputs))
        layr.append(struct.pack("<10I", l.kernel_h, l.kernel_w, l.stride_h, l.stride_w, l.dilation_h, l.dilation_w,
                                l.pad_top, l.pad_left, l.pad_bottom, l.pad_right))
        layr.append(struct.pack("<iiI", l.out_min, l.out_max, l.factor))
        if l.type in CONV_TYPES:
            wght += b"\0" * (-len(wght) % 4)  # block offsets are multiples of 4
            offset = len(wght)
            wght += _weight_block(l)
            layr.append(struct.pack("<II", offset, len(wght) - offset))
        else:
            layr.append(struct.pack("<II", 0, 0))
    return b"".join(layr), bytes(wght)


def to_bytes(m: QModel, check=True):
    """The .efm bytes of m; validates first (qmodel.validate) unless check is False (tests)."""
    if check:
        validate(m)
    layr, wght = _layr_wght(m)
    tags, bodies = list(SECTION_TAGS), [_meta(m), _tens(m), layr, wght]
    has_map = bool(len(m.class_map) or len(m.target_class_names))
    if has_map:
        tags.append(CMAP_TAG)
        bodies.append(_cmap(m))
    payload = b"".join(tag + struct.pack("<I", len(body)) + body for tag, body in zip(tags, bodies))
    if len(payload) > MAX_PAYLOAD_BYTES:
        raise EfmFormatError(f"{m.name}: payload of {len(payload)} bytes above the 256 MiB limit")
    version = VERSION_CLASS_MAP if has_map else VERSION
    header = MAGIC + struct.pack("<III", version, len(payload), zlib.crc32(payload) & 0xFFFFFFFF)
    return header + payload


def write(path, m: QModel):
    data = to_bytes(m)
    with open(path, "wb") as f:
        f.write(data)
    return data


class _Reader:
    def __init__(self, data, section):
        self.data, self.pos, self.section = data, 0, section

    def take(self, fmt):
        size = struct.calcsize(fmt)
        if self.pos + size > len(self.data):
            raise EfmFormatError(f"{self.section}: truncated")
        v = struct.unpack_from(fmt, self.data, self.pos)
        self.pos += size
        return v

    def raw(self, n):
        if self.pos + n > len(self.data):
            raise EfmFormatError(f"{self.section}: truncated")
        b = self.data[self.pos:self.pos + n]
        self.pos += n
        return b

    def done(self):
        if self.pos != len(self.data):
            raise EfmFormatError(f"{self.section}: {len(self.data) - self.pos} unexpected bytes at the end")


def from_bytes(data, check=True):
    """Parses .efm bytes into a QModel; raises EfmFormatError on framing faults, ModelError on
    semantic ones (when check)."""
    data = bytes(data)
    if len(data) < HEADER_BYTES or data[:4] != MAGIC:
        raise EfmFormatError("header: bad magic or truncated")
    version, size, crc = struct.unpack_from("<III", data, 4)
    if version not in (VERSION, VERSION_CLASS_MAP):
        raise EfmFormatError(f"header: version {version} unsupported")
    if size != len(data) - HEADER_BYTES:
        raise EfmFormatError(f"header: payload size {size} but {len(data) - HEADER_BYTES} bytes follow")
    payload = data[HEADER_BYTES:]
    if zlib.crc32(payload) & 0xFFFFFFFF != crc:
        raise EfmFormatError("header: payload CRC32 mismatch")
    bodies, pos = [], 0
    for tag in SECTION_TAGS + ((CMAP_TAG,) if version == VERSION_CLASS_MAP else ()):
        if pos + 8 > len(payload) or payload[pos:pos + 4] != tag:
            raise EfmFormatError(f"{tag.decode()}: missing or out of order")
        (length,) = struct.unpack_from("<I", payload, pos + 4)
        if pos + 8 + length > len(payload):
            raise EfmFormatError(f"{tag.decode()}: length runs past the payload")
        bodies.append(payload[pos + 8:pos + 8 + length])
        pos += 8 + length
    if pos != len(payload):
        raise EfmFormatError("payload: bytes after the last section")

    r = _Reader(bodies[0], "META")
    (name_len,) = r.take("<H")
    name = r.raw(name_len).decode()
    input_tensor, output_tensor, channels = r.take("<III")
    mean = list(r.take(f"<{channels}f"))
    scale = list(r.take(f"<{channels}f"))
    (classes,) = r.take("<I")
    class_names = []
    for _ in range(classes):
        (n,) = r.take("<B")
        class_names.append(r.raw(n).decode())
    r.done()

    r = _Reader(bodies[1], "TENS")
    (count,) = r.take("<I")
    tensors = []
    for _ in range(count):
        dtype, n, h, w, c, s, zp = r.take("<B3xIIIIfi")
        tensors.append(QTensor(h=h, w=w, c=c, scale=s, zero_point=zp, dtype=DType(dtype), n=n))
    r.done()

    r = _Reader(bodies[2], "LAYR")
    wght = bodies[3]
    (count,) = r.take("<I")
    layers = []
    for li in range(count):
        typ, act, mode, nin, output = r.take("<BBBBI")
        inputs = list(r.take(f"<{nin}I"))
        kh, kw, sh, sw, dh, dw, pt, pl, pb, pr = r.take("<10I")
        out_min, out_max, factor, woff, wbytes = r.take("<iiIII")
        l = QLayer(type=LayerType(typ), inputs=inputs, output=output, act=Activation(act), mode=UpsampleMode(mode),
                   kernel_h=kh, kernel_w=kw, stride_h=sh, stride_w=sw, dilation_h=dh, dilation_w=dw,
                   pad_top=pt, pad_left=pl, pad_bottom=pb, pad_right=pr, out_min=out_min, out_max=out_max,
                   factor=factor)
        if l.type in CONV_TYPES:
            if woff % 4 or woff + wbytes > len(wght):
                raise EfmFormatError(f"WGHT: layer {li}: block outside the section or misaligned")
            cout = tensors[output].c
            block = wght[woff:woff + wbytes]
            l.weight_scales = np.frombuffer(block, dtype="<f4", count=cout).astype(np.float32)
            l.bias = np.frombuffer(block, dtype="<i4", count=cout, offset=4 * cout).astype(np.int32)
            l.weights = np.frombuffer(block, dtype=np.int8, offset=8 * cout).copy()
            k = weights_per_channel(l, tensors[inputs[0]].c)
            if l.weights.size != k * cout:
                raise EfmFormatError(f"WGHT: layer {li}: {l.weights.size} weights, needs {k * cout}")
        elif woff or wbytes:
            raise EfmFormatError(f"WGHT: layer {li}: weight block on a layer without weights")
        layers.append(l)
    r.done()

    class_map, targets = [], []
    if version == VERSION_CLASS_MAP:
        r = _Reader(bodies[4], "CMAP")
        (count,) = r.take("<I")
        if count < 1:
            raise EfmFormatError("CMAP: no target classes")
        for _ in range(count):
            (n,) = r.take("<B")
            targets.append(r.raw(n).decode())
        (entries,) = r.take("<I")
        if entries < 1:
            raise EfmFormatError("CMAP: empty class map")
        class_map = list(r.raw(entries))
        r.done()

    m = QModel(name=name, input_tensor=input_tensor, output_tensor=output_tensor, input_mean=mean,
               input_scale=scale, class_names=class_names, tensors=tensors, layers=layers, class_map=class_map,
               target_class_names=targets)
    if check:
        validate(m)
    return m


def read(path, check=True):
    with open(path, "rb") as f:
        return from_bytes(f.read(), check)
