""".efm writer and reader (version 2, the class map: test_resize_pool_cmap.py): round trip, header and CRC, framing faults, semantic validation."""
import copy
import os
import struct
import unittest
import zlib

import numpy as np

from edgefusion_models import efm
from edgefusion_models.qmodel import ModelError, validate

from .helpers import FIXTURE_DIR, tiny_model


def models_equal(a, b):
    if (a.name, a.input_tensor, a.output_tensor, a.class_names) != (b.name, b.input_tensor, b.output_tensor, b.class_names):
        return False
    if np.float32(a.input_mean).tobytes() != np.float32(b.input_mean).tobytes():
        return False
    if np.float32(a.input_scale).tobytes() != np.float32(b.input_scale).tobytes():
        return False
    for ta, tb in zip(a.tensors, b.tensors):
        if (ta.dtype, ta.n, ta.shape, np.float32(ta.scale), ta.zero_point) != (tb.dtype, tb.n, tb.shape, np.float32(tb.scale), tb.zero_point):
            return False
    for la, lb in zip(a.layers, b.layers):
        fields = ("type", "act", "mode", "inputs", "output", "kernel_h", "kernel_w", "stride_h", "stride_w",
                  "dilation_h", "dilation_w", "pad_top", "pad_left", "pad_bottom", "pad_right", "out_min", "out_max",
                  "factor")
        if any(getattr(la, f) != getattr(lb, f) for f in fields):
            return False
        for f in ("weight_scales", "bias", "weights"):
            va, vb = getattr(la, f), getattr(lb, f)
            if (va is None) != (vb is None) or (va is not None and np.asarray(va).tobytes() != np.asarray(vb).tobytes()):
                return False
    return len(a.tensors) == len(b.tensors) and len(a.layers) == len(b.layers)


class EfmTest(unittest.TestCase):
    def test_round_trip(self):
        m = tiny_model()
        data = efm.to_bytes(m)
        back = efm.from_bytes(data)
        self.assertTrue(models_equal(m, back))
        self.assertEqual(efm.to_bytes(back), data)

    def test_header_and_crc(self):
        data = efm.to_bytes(tiny_model())
        magic, version, size, crc = struct.unpack_from("<4sIII", data)
        self.assertEqual((magic, version, size), (b"EFM1", 1, len(data) - 16))
        self.assertEqual(crc, zlib.crc32(data[16:]))
        # Sections in order, each "tag, u32 length, body"; the weight blocks start at multiples of 4.
        pos, tags = 16, []
        while pos < len(data):
            tag, length = struct.unpack_from("<4sI", data, pos)
            tags.append(tag)
            pos += 8 + length
        self.assertEqual(tags, [b"META", b"TENS", b"LAYR", b"WGHT"])
        self.assertEqual(pos, len(data))

    def test_weight_blocks_are_padded_to_multiples_of_4(self):
        # Two pointwise convolutions: the first block is 8 + 3 bytes, so the second starts at 12.
        from edgefusion_models.qmodel import DType, LayerType, QLayer, QModel, QTensor
        t = [QTensor(2, 2, 3, 0.1, 0), QTensor(2, 2, 1, 0.1, 0), QTensor(2, 2, 3, 0.1, 0),
             QTensor(2, 2, 3, dtype=DType.FLOAT32)]
        l1 = QLayer(LayerType.POINTWISE_CONV2D, [0], 1, weight_scales=np.float32([0.01]), bias=np.int32([5]),
                    weights=np.int8([1, -2, 3]))
        l2 = QLayer(LayerType.POINTWISE_CONV2D, [1], 2, weight_scales=np.float32([0.01] * 3), bias=np.int32([1, 2, 3]),
                    weights=np.int8([4, 5, 6]))
        m = QModel("pad", 0, 3, [0.0] * 3, [1.0] * 3, ["a", "b", "c"], t,
                   [l1, l2, QLayer(LayerType.SOFTMAX, [2], 3)])
        data = efm.to_bytes(m)
        back = efm.from_bytes(data)
        self.assertTrue(models_equal(m, back))
        wght = data.index(b"WGHT")
        self.assertEqual(struct.unpack_from("<I", data, wght + 4)[0], 12 + 3 * 8 + 3)
        self.assertEqual(data[wght + 8 + 11], 0)  # the padding byte
        layr = data.index(b"LAYR")
        second = layr + 12 + (8 + 4 + 52 + 8)  # one-input records of 72 bytes
        self.assertEqual(struct.unpack_from("<II", data, second + 8 + 4 + 52), (12, 3 * 8 + 3))

    def test_reader_rejects_corruption(self):
        data = bytearray(efm.to_bytes(tiny_model()))
        bad = bytearray(data)
        bad[40] ^= 1
        with self.assertRaisesRegex(efm.EfmFormatError, "CRC"):
            efm.from_bytes(bad)
        with self.assertRaisesRegex(efm.EfmFormatError, "payload size"):
            efm.from_bytes(data[:-1])
        bad = bytearray(data)
        bad[4] = 3  # 1 and 2 (with a class map) are read
        with self.assertRaisesRegex(efm.EfmFormatError, "version"):
            efm.from_bytes(bad)
        with self.assertRaisesRegex(efm.EfmFormatError, "magic"):
            efm.from_bytes(b"EFM2" + bytes(data[4:]))

    def test_validation(self):
        m = tiny_model()
        bad = copy.deepcopy(m)
        bad.layers[0].weights[3] = -128
        with self.assertRaisesRegex(ModelError, "-128"):
            efm.to_bytes(bad)
        bad = copy.deepcopy(m)
        bad.tensors[8].zero_point += 1  # bilinear output must keep its input's quantisation
        with self.assertRaisesRegex(ModelError, "upsample"):
            validate(bad)
        bad = copy.deepcopy(m)
        bad.layers[1].weight_scales[0] = 1e-38  # multiplier below FLT_MIN
        with self.assertRaisesRegex(ModelError, "normal float32"):
            validate(bad)
        bad = copy.deepcopy(m)
        bad.layers[2].bias[0] = (1 << 30) + 1
        with self.assertRaisesRegex(ModelError, "2\\^30"):
            validate(bad)
        bad = copy.deepcopy(m)
        bad.layers[5].pad_top = 2  # pool padding must be below the window
        with self.assertRaisesRegex(ModelError, "smaller than the window"):
            validate(bad)

    def test_reads_the_committed_fixture(self):
        path = os.path.join(FIXTURE_DIR, "model.efm")
        with open(path, "rb") as f:
            data = f.read()
        m = efm.from_bytes(data)
        self.assertEqual(efm.to_bytes(m), data)
        self.assertEqual(m.class_names[0], "unknown")
        self.assertEqual((m.tensors[m.input_tensor].shape, m.tensors[m.output_tensor].shape),
                         ((120, 160, 4), (120, 160, 14)))


if __name__ == "__main__":
    unittest.main()
