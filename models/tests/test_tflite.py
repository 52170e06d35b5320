"""The TFLite reader, the float reference of a TFLite graph (operator by operator against direct
definitions), and the importer's float graph against that reference on the shared DeepLab file."""
import os
import unittest

import numpy as np

from edgefusion_models import tflite, tflite_ref

from .helpers import REPO_ROOT

DEEPLAB_DIR = os.path.join(os.path.dirname(REPO_ROOT), "shared", "models", "deeplabv3-mnv2-ade20k")
DEEPLAB = os.path.join(DEEPLAB_DIR, "deeplabv3-mnv2-ade20k.tflite")


def have_deeplab():
    return os.path.exists(DEEPLAB)


def naive_conv(x, w, b, stride, dil, pads):
    """Direct definition: out[y, x, o] = b[o] + sum w[o, ky, kx, i] * xpad[y*s + ky*d, x*s + kx*d, i]."""
    n, h, wd, c = x.shape
    cout, kh, kw, _ = w.shape
    xp = np.pad(x, ((0, 0), (pads[0], pads[2]), (pads[1], pads[3]), (0, 0)))
    oh = (h + pads[0] + pads[2] - (kh - 1) * dil[0] - 1) // stride[0] + 1
    ow = (wd + pads[1] + pads[3] - (kw - 1) * dil[1] - 1) // stride[1] + 1
    out = np.zeros((n, oh, ow, cout), np.float64)
    for oy in range(oh):
        for ox in range(ow):
            for ky in range(kh):
                for kx in range(kw):
                    v = xp[:, oy * stride[0] + ky * dil[0], ox * stride[1] + kx * dil[1], :]
                    out[:, oy, ox, :] += v @ w[:, ky, kx, :].T
    return out + b


class ReferenceOps(unittest.TestCase):
    def setUp(self):
        self.rng = np.random.RandomState(4)

    def test_same_padding_puts_the_smaller_half_first(self):
        self.assertEqual(tflite_ref.same_pads(513, 3, 2, 1), (257, 1, 1))
        self.assertEqual(tflite_ref.same_pads(64, 3, 2, 1), (32, 0, 1))
        self.assertEqual(tflite_ref.same_pads(65, 3, 1, 4), (65, 4, 4))

    def test_conv_matches_the_definition(self):
        x = self.rng.randn(1, 9, 7, 3).astype(np.float32)
        w = self.rng.randn(5, 3, 3, 3).astype(np.float32)
        b = self.rng.randn(5).astype(np.float32)
        for stride, dil in (((2, 2), (1, 1)), ((1, 1), (2, 2)), ((1, 2), (1, 1))):
            _, pt, pb = tflite_ref.same_pads(9, 3, stride[0], dil[0])
            _, pl, pr = tflite_ref.same_pads(7, 3, stride[1], dil[1])
            got = tflite_ref.conv2d(x, w, b, stride, dil, "SAME", "NONE")
            np.testing.assert_allclose(got, naive_conv(x, w, b, stride, dil, (pt, pl, pb, pr)), atol=1e-4)
        got = tflite_ref.conv2d(x, w, b, (1, 1), (1, 1), "VALID", "RELU6")
        np.testing.assert_allclose(got, np.clip(naive_conv(x, w, b, (1, 1), (1, 1), (0, 0, 0, 0)), 0, 6), atol=1e-4)

    def test_depthwise_matches_the_definition(self):
        x = self.rng.randn(1, 11, 10, 4).astype(np.float32)
        w = self.rng.randn(1, 3, 3, 4).astype(np.float32)
        b = self.rng.randn(4).astype(np.float32)
        got = tflite_ref.depthwise(x, w, b, (2, 2), (1, 1), "SAME", "RELU", 1)
        want = np.zeros_like(got, dtype=np.float64)
        for c in range(4):
            dense = np.zeros((1, 3, 3, 1))
            dense[0, :, :, 0] = w[0, :, :, c]
            _, pt, pb = tflite_ref.same_pads(11, 3, 2, 1)
            _, pl, pr = tflite_ref.same_pads(10, 3, 2, 1)
            want[..., c] = naive_conv(x[..., c:c + 1], dense, b[c:c + 1], (2, 2), (1, 1), (pt, pl, pb, pr))[..., 0]
        np.testing.assert_allclose(got, np.maximum(want, 0), atol=1e-5)

    def test_space_to_batch_pair_is_a_dilated_depthwise(self):
        # What TensorFlow wrote for an atrous depthwise convolution equals the dilated one with SAME padding.
        for rate, size in ((2, 65), (4, 65), (2, 33), (4, 17)):
            x = self.rng.randn(1, size, size, 3).astype(np.float32)
            w = self.rng.randn(1, 3, 3, 3).astype(np.float32)
            b = np.zeros(3, np.float32)
            pads, crops = zip(*[tflite_ref._s2b_pads(size, rate, (rate, rate)) for _ in range(2)])
            y = tflite_ref.space_to_batch(x, (rate, rate), pads)
            y = tflite_ref.depthwise(y, w, b, (1, 1), (1, 1), "VALID", "NONE", 1)
            y = tflite_ref.batch_to_space(y, (rate, rate), crops)
            direct = tflite_ref.depthwise(x, w, b, (1, 1), (rate, rate), "SAME", "NONE", 1)
            np.testing.assert_allclose(y, direct, atol=1e-5, err_msg=f"rate {rate} size {size}")

    def test_space_to_batch_layout(self):
        x = np.arange(16, dtype=np.float32).reshape(1, 4, 4, 1)
        y = tflite_ref.space_to_batch(x, (2, 2), ((0, 0), (0, 0)))
        # Batch (by * 2 + bx) holds the pixels at (2i + by, 2j + bx).
        np.testing.assert_array_equal(y[1, :, :, 0], [[1, 3], [9, 11]])
        np.testing.assert_array_equal(tflite_ref.batch_to_space(y, (2, 2), ((0, 0), (0, 0))), x)

    def test_average_pool_counts_only_inside_positions(self):
        x = np.ones((1, 3, 3, 1), np.float32)
        x[0, 0, 0, 0] = 10
        y = tflite_ref.average_pool(x, 3, 3, (1, 1), "SAME", "NONE")
        self.assertAlmostEqual(float(y[0, 0, 0, 0]), (10 + 3) / 4, places=5)  # 2x2 inside
        g = tflite_ref.average_pool(x, 3, 3, (1, 1), "VALID", "NONE")
        self.assertEqual(g.shape, (1, 1, 1, 1))
        self.assertAlmostEqual(float(g[0, 0, 0, 0]), 18 / 9, places=5)

    def test_resize_align_corners(self):
        x = np.array([0.0, 4.0], np.float32).reshape(1, 1, 2, 1)
        y = tflite_ref.resize_bilinear(x, 1, 5, True, False)
        np.testing.assert_allclose(y[0, 0, :, 0], [0, 1, 2, 3, 4])
        one = np.full((1, 1, 1, 2), 3.0, np.float32)
        np.testing.assert_allclose(tflite_ref.resize_bilinear(one, 4, 3, True, False), np.full((1, 4, 3, 2), 3.0))
        # Without align_corners: o * in / out (the last output clamps to the last input).
        y = tflite_ref.resize_bilinear(x, 1, 4, False, False)
        np.testing.assert_allclose(y[0, 0, :, 0], [0, 2, 4, 4])

    def test_size_map_keeps_alignment(self):
        s = tflite_ref.SizeMap((513, 513), (257, 321))
        self.assertEqual((s.dim(65, 0), s.dim(65, 1), s.dim(129, 0), s.dim(513, 1)), (33, 41, 65, 321))
        with self.assertRaises(tflite_ref.RefError):
            tflite_ref.SizeMap((513, 513), (256, 256))


class Reader(unittest.TestCase):
    def test_refuses_what_is_not_tflite(self):
        with self.assertRaisesRegex(tflite.TFLiteError, "too short"):
            tflite.parse(b"abc", "x.tflite")
        with self.assertRaisesRegex(tflite.TFLiteError, "file identifier"):
            tflite.parse(b"\x10\x00\x00\x00ONNX" + bytes(32), "x.tflite")

    # Reproducers of tests/fuzz/tflite/fuzz_tflite.py's findings (issue 34), minimised: one-tensor
    # models that edgefusion_models.tflite_write builds. Before the fix, dequantize() raised an
    # IndexError (a quantised dimension beyond the shape) and a ValueError (per-axis scales that do
    # not match that dimension), and parse() a ValueError from numpy's reshape (two -1 dimensions).
    QDIM_OUT_OF_RANGE = bytes.fromhex(
        "1800000054464c330e001800040008000c00100014000000100000000300000010000000100000001400000018000000"
        "000000000100000028000000000000000000000002000000340000003c0000000e001800040008000c00100014000000"
        "100000002c00000030000000340000003800000038000000040004000400000006000800040000000800000040000000"
        "01000000500000000100000000000000010000000000000000000000040000006d61696e000000000000000000000000"
        "00000000000000000000000002000000010200000e001800040008000c00100014000000100000001400000009000000"
        "01000000100000002800000001000000020000000100000074000000120010000000000004000800000000000c000000"
        "140000000c000000140000000300000002000000cdcccc3dcdcc4c3e0200000000000000000000000000000000000000")
    SCALES_DO_NOT_MATCH = bytes.fromhex(
        "1800000054464c330e001800040008000c00100014000000100000000300000010000000100000001400000018000000"
        "000000000100000028000000000000000000000002000000340000003c0000000e001800040008000c00100014000000"
        "100000002c00000030000000340000003800000038000000040004000400000006000800040000000800000040000000"
        "01000000500000000100000000000000010000000000000000000000040000006d61696e000000000000000000000000"
        "00000000000000000000000002000000010200000e001800040008000c00100014000000100000001400000009000000"
        "010000001c00000034000000040000000100000001000000010000000200000001000000740000001200100000000000"
        "04000800000000000c000000140000000c000000180000000300000003000000cdcccc3dcdcc4c3e9a99993e03000000"
        "000000000000000000000000000000000000000000000000")
    TWO_UNKNOWN_DIMENSIONS = bytes.fromhex(
        "1800000054464c330e001800040008000c00100014000000100000000300000010000000100000001400000018000000"
        "000000000100000028000000000000000000000002000000340000003c0000000e001800040008000c00100014000000"
        "100000002c00000030000000340000003800000038000000040004000400000006000800040000000800000040000000"
        "010000004c0000000100000000000000010000000000000000000000040000006d61696e000000000000000000000000"
        "00000000000000000000000001000000070000000c001400040008000c0010000c000000100000000900000001000000"
        "1000000002000000ffffffffffffffff010000007400")

    def test_fuzz_findings_are_clear_errors(self):
        cases = ((self.QDIM_OUT_OF_RANGE, "2 per-axis scales along dimension 3 of shape \\[2\\]"),
                 (self.SCALES_DO_NOT_MATCH, "3 per-axis scales along dimension 3 of shape \\[1, 1, 1, 2\\]"),
                 (self.TWO_UNKNOWN_DIMENSIONS, "constant of shape \\[-1, -1\\] has a negative dimension"))
        for data, message in cases:
            with self.assertRaisesRegex(tflite.TFLiteError, "fuzz.tflite: tensor 0 't': " + message):
                tflite.parse(data, "fuzz.tflite")

    def test_fuzz_reproducers_are_what_the_writer_builds(self):
        # The bytes above stay explainable: the writer makes them from these descriptions.
        from edgefusion_models import tflite_write

        def one(shape, data, scale=None, zero_point=None, qdim=0):
            m = tflite_write.ModelBuilder("")
            t = m.tensor("t", [len(data)], data=np.array(data), scale=scale, zero_point=zero_point, qdim=qdim)
            m.tensors[t].fields[0] = ("vector:i", shape)
            return m.write([t], [t])
        self.assertEqual(one([2], [1, 2], [0.1, 0.2], [0, 0], 3), self.QDIM_OUT_OF_RANGE)
        self.assertEqual(one([1, 1, 1, 2], [1, 2], [0.1, 0.2, 0.3], [0, 0, 0], 3), self.SCALES_DO_NOT_MATCH)
        self.assertEqual(one([-1, -1], [7]), self.TWO_UNKNOWN_DIMENSIONS)

    def test_writer_seeds_read_back(self):
        # The fuzzer's seeds (tests/fuzz/make_corpus.sh): every operator and tensor kind decoded.
        from edgefusion_models import tflite_write
        m = tflite.parse(tflite_write.tiny_int8_model(), "seed.tflite")
        self.assertEqual([o.opcode for o in m.operators],
                         ["CONV_2D", "DEPTHWISE_CONV_2D", "AVERAGE_POOL_2D", "MAX_POOL_2D", "ADD", "RELU6",
                          "CONCATENATION", "RESIZE_BILINEAR", "HARD_SWISH", "SOFTMAX", "DEQUANTIZE",
                          "CUSTOM:EdgeFusionNoop"])
        self.assertEqual(m.operators[1].options["stride_h"], 2)
        self.assertEqual(m.operators[-1].inputs[-1], -1)
        w = m.tensors[m.operators[0].inputs[1]]
        self.assertEqual((w.shape, w.scale.size, w.quantized_dimension), ([4, 3, 3, 3], 4, 0))
        self.assertEqual(tflite.dequantize(w).shape, (4, 3, 3, 3))
        f = tflite.parse(tflite_write.tiny_float_model(), "float.tflite")
        self.assertAlmostEqual(float(tflite.dequantize(f.tensors[1]).sum()), 1.5, places=5)

    @unittest.skipUnless(have_deeplab(), "../shared/models/deeplabv3-mnv2-ade20k absent")
    def test_truncated_file_names_the_place(self):
        with open(DEEPLAB, "rb") as f:
            data = f.read()
        for cut in (64, 1000, len(data) // 2):
            with self.assertRaises(tflite.TFLiteError) as ctx:
                tflite.parse(data[:cut], "cut.tflite")
            self.assertIn("cut.tflite", str(ctx.exception))

    @unittest.skipUnless(have_deeplab(), "../shared/models/deeplabv3-mnv2-ade20k absent")
    def test_deeplab_graph_facts(self):
        # The facts its README states, read by our reader.
        m = tflite.read(DEEPLAB)
        counts = {}
        for op in m.operators:
            counts[op.opcode] = counts.get(op.opcode, 0) + 1
        self.assertEqual(len(m.operators), 135)
        self.assertEqual(counts, {"CONV_2D": 41, "DEPTHWISE_CONV_2D": 19, "ADD": 20, "MUL": 10,
                                  "SPACE_TO_BATCH_ND": 10, "BATCH_TO_SPACE_ND": 10, "DEQUANTIZE": 17,
                                  "RESIZE_BILINEAR": 5, "CONCATENATION": 2, "AVERAGE_POOL_2D": 1})
        self.assertEqual(m.tensors[m.inputs[0]].shape, [1, 513, 513, 3])
        self.assertEqual(m.tensors[m.outputs[0]].shape, [1, 513, 513, 151])
        params = sum(t.data.size for t in m.tensors if t.data is not None and t.data.ndim == 4)
        self.assertAlmostEqual(params / 1e6, 2.29, delta=0.05)


@unittest.skipUnless(have_deeplab(), "../shared/models/deeplabv3-mnv2-ade20k absent")
class DeepLabImport(unittest.TestCase):
    """The importer's folded float graph computes what the file's own operators compute."""

    @classmethod
    def setUpClass(cls):
        cls.model = tflite.read(DEEPLAB)

    def test_reference_runs_at_other_sizes(self):
        x = np.random.RandomState(1).uniform(-1, 1, (1, 129, 161, 3)).astype(np.float32)
        y = tflite_ref.run(self.model, x, size=(129, 161))
        self.assertEqual(y.shape, (1, 129, 161, 151))

    def test_float_graph_equals_the_reference(self):
        from edgefusion_models import graph
        from edgefusion_models.from_tflite import from_tflite
        size = (129, 161)
        g = from_tflite(self.model, size)
        kinds = [n.kind for n in g.nodes]
        self.assertNotIn("batchnorm", kinds)
        self.assertEqual(sum(n.kind == "depthwise_conv2d" and n.dilation != (1, 1) for n in g.nodes), 10)
        x = np.random.RandomState(2).uniform(-1, 1, (1,) + size + (3,)).astype(np.float32)
        # The reference's logits at stride 4 (before the last resize to the input size).
        ref = tflite_ref.run(self.model, x, size=size, stop_at=len(self.model.operators) - 2)
        vals = graph.forward(g, x, keep=True)
        logits = vals[g.nodes[-1].inputs[0]]
        self.assertEqual(logits.shape, ref.shape)
        np.testing.assert_allclose(logits, ref, atol=2e-3 * float(np.abs(ref).max()))


if __name__ == "__main__":
    unittest.main()
