"""What a DeepLabv3 import needs from the model tools: the resize_bilinear node (float forward with
TensorFlow's align_corners, quantised with its input's scale and zero point, written as layer type
10), global average pools above the 31 of ordinary windows, and the class map of version 2 files.

The C++ runtime checks the same integers through a committed fixture, tests/data/nn/resize_pool_cmap/
(helpers.resize_model(), its int8 input and the integer reference's outputs in golden files), which
tests/nn/test_nn_resize_golden.cpp runs with every kernel variant. Regenerate it after an intended
change with
    cd models && /usr/bin/python3 -m tests.test_resize_pool_cmap --write
"""
import copy
import os
import struct
import sys
import tempfile
import unittest

import numpy as np

from edgefusion_models import efm, float_ops, golden, graph, int8_ref
from edgefusion_models.graph import Graph, Node
from edgefusion_models.qmodel import LayerType, ModelError, QLayer, QTensor, is_global_pool, resize_tap, validate
from edgefusion_models.quantize import quantize

from .helpers import REPO_ROOT, random_input, resize_model

RESIZE_FIXTURE_DIR = os.path.join(REPO_ROOT, "tests", "data", "nn", "resize_pool_cmap")
FIXTURE_FILES = ("model.efm", golden.INPUT_FILE, golden.ROWS_FILE, golden.MANIFEST)


def write_fixture(directory):
    """The fixture's four files: resize_model(), a random int8 input (seed 11), int8_ref's outputs."""
    m = resize_model()
    data = efm.to_bytes(m)
    os.makedirs(directory, exist_ok=True)
    with open(os.path.join(directory, "model.efm"), "wb") as f:
        f.write(data)
    x = random_input(m, 11)
    probs, tensors = int8_ref.run(m, x, keep_tensors=True)
    golden.write(directory, m, data, x, probs, tensors,
                 "resize_bilinear up / broadcast / down, a 33x49 global average pool and a class map "
                 "(models/tests/test_resize_pool_cmap.py)")


class ResizeFloat(unittest.TestCase):
    def test_align_corners(self):
        x = np.arange(2 * 3 * 2, dtype=np.float32).reshape(1, 2, 3, 2)
        y = float_ops.resize_bilinear(x, (3, 5))
        self.assertEqual(y.shape, (1, 3, 5, 2))
        np.testing.assert_array_equal(y[0, 0, 0], x[0, 0, 0])      # corners map to corners
        np.testing.assert_array_equal(y[0, -1, -1], x[0, -1, -1])
        np.testing.assert_allclose(y[0, 1, 2], x[0, :, 1].mean(axis=0))  # centre of the middle column
        np.testing.assert_allclose(y[0, 0, 1], 0.5 * x[0, 0, 0] + 0.5 * x[0, 0, 1], rtol=1e-6)  # source 2/4
        z = float_ops.resize_bilinear(x, (2, 4))  # columns at sources 0, 2/3, 4/3, 2
        np.testing.assert_allclose(z[0, 0, 1], x[0, 0, 0] / 3 + 2 * x[0, 0, 1] / 3, rtol=1e-6)
        np.testing.assert_array_equal(float_ops.resize_bilinear(x[:, :1, :1], (4, 4)),
                                      np.broadcast_to(x[:, :1, :1], (1, 4, 4, 2)))
        np.testing.assert_array_equal(float_ops.resize_bilinear(x, (1, 1)), x[:, :1, :1])

    def test_graph_node(self):
        n = Node(name="r", kind="resize_bilinear", inputs=["x"], output="y", size=(7, 9))
        g = Graph(name="g", input="x", input_shape=(4, 5, 3), output="y", nodes=[n], mean=[0.0] * 3, scale=[1.0] * 3)
        self.assertEqual(graph.infer_shapes(g)["y"], (7, 9, 3))
        bad = copy.deepcopy(g)
        bad.nodes[0].size = (0, 9)
        with self.assertRaisesRegex(graph.UnsupportedModelError, "output size"):
            graph.infer_shapes(bad)


class ResizeIntegerRule(unittest.TestCase):
    def test_taps(self):
        self.assertEqual([resize_tap(o, 3, 4) for o in range(4)], [(0, 1, 0), (0, 1, 1365), (1, 2, 683), (2, 2, 0)])
        self.assertEqual([resize_tap(o, 33, 65)[2] for o in range(4)], [0, 1024, 0, 1024])
        self.assertEqual(resize_tap(5, 1, 33), (0, 0, 0))
        self.assertEqual(resize_tap(0, 17, 1), (0, 0, 0))

    def test_within_one_step_of_the_float_resize(self):
        rs = np.random.RandomState(3)
        for h, w, oh, ow in ((17, 25, 33, 49), (33, 33, 17, 17), (20, 20, 33, 33), (1, 1, 5, 3)):
            x = rs.randint(-128, 128, size=(h, w, 5)).astype(np.int8)
            q = int8_ref.resize_bilinear(x, QTensor(h=oh, w=ow, c=5)).astype(np.float64)
            f = float_ops.resize_bilinear(x[None].astype(np.float64), (oh, ow))[0]
            self.assertLessEqual(np.abs(q - np.round(f)).max(), 1.0)


class Validation(unittest.TestCase):
    def test_resize_refusals(self):
        m = resize_model()
        bad = copy.deepcopy(m)
        bad.tensors[2].scale = 0.051
        with self.assertRaisesRegex(ModelError, "resize_bilinear.*quantisation must match"):
            validate(bad)
        bad = copy.deepcopy(m)
        bad.tensors[2].zero_point = 3
        with self.assertRaisesRegex(ModelError, "quantisation must match"):
            validate(bad)
        bad = copy.deepcopy(m)
        bad.tensors[6].c = 31
        with self.assertRaisesRegex(ModelError, "layer 5 \\(resize_bilinear\\): changes channels 32 -> 31"):
            validate(bad)

    def test_global_pool(self):
        m = resize_model()
        gap = m.layers[2]
        self.assertTrue(is_global_pool(gap, m.tensors[2]))
        bad = copy.deepcopy(m)  # a 33x49 window that is not the whole input
        bad.tensors[2].w = 50
        bad.tensors[3].w = 2
        with self.assertRaisesRegex(ModelError, "kernel 33x49 outside 1..31.*global average pool"):
            validate(bad)
        bad = copy.deepcopy(m)
        bad.layers[2].stride_h = 2
        with self.assertRaisesRegex(ModelError, "kernel 33x49"):
            validate(bad)
        # Up to 256 x 256; the one multiplier of the count 256 * 256 only.
        t_in, t_out = QTensor(h=256, w=256, c=3, scale=0.1), QTensor(h=1, w=1, c=3, scale=0.1)
        l = QLayer(LayerType.AVG_POOL, [0], 1, kernel_h=256, kernel_w=256)
        self.assertTrue(is_global_pool(l, t_in))
        x = np.full((256, 256, 3), 127, np.int8)
        x[::2, :, 1] = -128
        y = int8_ref.avg_pool(l, x, t_in, t_out)
        np.testing.assert_array_equal(y.reshape(-1), [127, 0, 127])  # mean -0.5 -> round half even 0

    def test_class_map_refusals(self):
        m = resize_model()
        for change, pattern in ((lambda b: b.class_map.__setitem__(2, 4), "output channel 2 maps to class 4"),
                                (lambda b: b.class_map.append(0), "8 map entries but the output has 7"),
                                (lambda b: b.target_class_names.clear(), "a class map needs target class names"),
                                (lambda b: b.class_map.clear(), "a class map needs target class names"),
                                (lambda b: b.target_class_names.__setitem__(1, ""), "target class 1 name"),
                                (lambda b: setattr(b, "target_class_names", ["t"] * 257), "257 target classes")):
            bad = copy.deepcopy(m)
            change(bad)
            with self.assertRaisesRegex(ModelError, "CMAP: " + pattern):
                validate(bad)


class ClassMapFile(unittest.TestCase):
    def test_round_trip_as_version_2(self):
        m = resize_model()
        data = efm.to_bytes(m)
        self.assertEqual(struct.unpack_from("<I", data, 4)[0], efm.VERSION_CLASS_MAP)
        cmap = data.index(b"CMAP")
        body = 4 + sum(1 + len(n) for n in m.target_class_names) + 4 + 7
        self.assertEqual(struct.unpack_from("<I", data, cmap + 4)[0], body)
        self.assertEqual(cmap + 8 + body, len(data))  # the last section
        back = efm.from_bytes(data)
        self.assertEqual((back.class_map, back.target_class_names), (m.class_map, m.target_class_names))
        self.assertEqual(efm.to_bytes(back), data)
        # Without the map: version 1 and no CMAP.
        plain = copy.deepcopy(m)
        plain.class_map, plain.target_class_names = [], []
        d1 = efm.to_bytes(plain)
        self.assertEqual(struct.unpack_from("<I", d1, 4)[0], efm.VERSION)
        self.assertNotIn(b"CMAP", d1)
        self.assertEqual(d1[16:], data[16:cmap])  # the same four sections

    def test_framing_faults(self):
        data = bytearray(efm.to_bytes(resize_model()))
        cmap = data.index(b"CMAP")
        cut = data[:cmap]  # version 2 without CMAP
        cut[8:12] = struct.pack("<I", len(cut) - 16)
        cut[12:16] = struct.pack("<I", __import__("zlib").crc32(bytes(cut[16:])))
        with self.assertRaisesRegex(efm.EfmFormatError, "CMAP: missing"):
            efm.from_bytes(cut)
        v1 = bytearray(data)  # version 1 with CMAP
        v1[4] = 1
        with self.assertRaisesRegex(efm.EfmFormatError, "bytes after the last section"):
            efm.from_bytes(v1)


class QuantiseResizeGraph(unittest.TestCase):
    """A float DeepLab-like head through calibration and quantisation: resize nodes keep their input's
    quantisation, the global pool and class map pass through, and the int8 model follows the float one."""

    def test_quantise(self):
        rs = np.random.RandomState(8)
        w1 = rs.normal(0, 0.3, (8, 4)).astype(np.float32)
        w2 = rs.normal(0, 0.3, (5, 16)).astype(np.float32)
        nodes = [Node("pw1", "pointwise_conv2d", ["x"], "a", weight=w1, bias=np.zeros(8, np.float32)),
                 Node("up", "resize_bilinear", ["a"], "b", size=(33, 49)),
                 Node("gap", "avg_pool", ["b"], "c", kernel=(33, 49)),
                 Node("bc", "resize_bilinear", ["c"], "d", size=(33, 49)),
                 Node("cat", "concat", ["b", "d"], "e"),
                 Node("pw2", "pointwise_conv2d", ["e"], "f", weight=w2, bias=np.zeros(5, np.float32)),
                 Node("down", "resize_bilinear", ["f"], "g", size=(20, 20)),
                 Node("sm", "softmax", ["g"], "p")]
        g = Graph(name="head", input="x", input_shape=(17, 25, 4), output="p", nodes=nodes,
                  mean=[128.0, 128.0, 128.0, 2.0], scale=[1 / 64, 1 / 64, 1 / 64, 0.5],
                  class_names=[f"k{i}" for i in range(5)], class_map=[0, 1, 1, 2, 0],
                  target_class_names=["unknown", "a", "b"])
        raw = np.concatenate([rs.uniform(0, 255, (6, 17, 25, 3)), rs.uniform(0, 5, (6, 17, 25, 1))], axis=3)
        qm = quantize(g, raw.astype(np.float32))
        ids = {n: i for i, n in enumerate(qm.tensor_names)}
        types = [l.type for l in qm.layers]
        self.assertEqual(types.count(LayerType.RESIZE_BILINEAR), 3)
        for a, b in (("a", "b"), ("c", "d"), ("f", "g")):
            ta, tb = qm.tensors[ids[a]], qm.tensors[ids[b]]
            self.assertEqual((np.float32(ta.scale), ta.zero_point), (np.float32(tb.scale), tb.zero_point))
        self.assertEqual(qm.tensors[ids["g"]].shape, (20, 20, 5))
        self.assertEqual((qm.class_map, qm.target_class_names), ([0, 1, 1, 2, 0], ["unknown", "a", "b"]))
        back = efm.from_bytes(efm.to_bytes(qm))
        self.assertEqual(back.layers[2].kernel_h, 33)
        frame = raw[0].astype(np.float32)
        probs, _ = int8_ref.run(qm, int8_ref.quantize_input(frame, qm))
        fprobs = graph.forward(g, graph.normalise(g, frame[None]))[0]
        self.assertLess(np.abs(probs - fprobs).mean(), 0.03)
        self.assertGreater(np.mean(probs.argmax(2) == fprobs.argmax(2)), 0.85)


class Fixture(unittest.TestCase):
    def test_committed_fixture_is_what_the_tools_make(self):
        with tempfile.TemporaryDirectory() as tmp:
            write_fixture(tmp)
            for name in FIXTURE_FILES:
                with open(os.path.join(tmp, name), "rb") as f:
                    new = f.read()
                with open(os.path.join(RESIZE_FIXTURE_DIR, name), "rb") as f:
                    committed = f.read()
                self.assertTrue(new == committed, f"{name} differs from the committed fixture (see this file's docstring)")


if __name__ == "__main__":
    if sys.argv[1:] == ["--write"]:
        write_fixture(RESIZE_FIXTURE_DIR)
        print(f"wrote {RESIZE_FIXTURE_DIR}")
    else:
        unittest.main()
