"""Post-training quantisation: the int8 model agrees with the float one, and follows the format's
quantisation rules."""
import unittest

import numpy as np
import torch

from edgefusion_models import graph, int8_ref
from edgefusion_models.from_torch import from_module
from edgefusion_models.qmodel import (Activation, LayerType, MAX_ABS_BIAS, conv_real_multiplier, f32,
                                      make_multiplier, ratio_real_multiplier)
from edgefusion_models.quantize import out_range, qparams, quantize, quantize_conv
from edgefusion_models.random_init import random_frames, raw_input

from .helpers import random_net, random_net_graph
from .test_from_torch import OtherOps, randomise_bn


def dequant(q, t):
    return np.float32(t.scale) * (q.astype(np.float32) - t.zero_point)


class QuantisedAgreesWithFloat(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        _, cls.raw = random_net()
        cls.g = random_net_graph()
        cls.qm = quantize(cls.g, cls.raw)

    def check_frame(self, raw_frame):
        probs, tensors = int8_ref.run(self.qm, int8_ref.quantize_input(raw_frame, self.qm), keep_tensors=True)
        vals = graph.forward(self.g, graph.normalise(self.g, raw_frame[None]), keep=True)
        logits_id = self.qm.layers[-1].inputs[0]
        q_logits = dequant(tensors[logits_id], self.qm.tensors[logits_id])
        f_logits = vals[self.g.nodes[-1].inputs[0]][0]
        corr = np.corrcoef(q_logits.reshape(-1), f_logits.reshape(-1))[0, 1]
        agree = np.mean(probs.argmax(2) == vals[self.g.output][0].argmax(2))
        self.assertGreater(corr, 0.98)
        self.assertGreater(agree, 0.85)
        self.assertLess(np.abs(probs - vals[self.g.output][0]).mean(), 0.03)
        np.testing.assert_allclose(probs.sum(2), 1.0, atol=1e-5)

    def test_calibration_frame(self):
        self.check_frame(self.raw[0])

    def test_unseen_frame(self):
        rgb, depth = random_frames(99, 1)
        self.check_frame(raw_input(rgb, depth)[0])

    def test_format_rules(self):
        qm = self.qm
        t_in = qm.tensors[qm.input_tensor]
        # Input from the normalisation: R, G, B 0..255 and depth 0..6 m all map to [-1, 1].
        self.assertEqual(np.float32(t_in.scale), np.float32(2.0 / 255.0))
        self.assertIn(t_in.zero_point, (-1, 0))
        for l in qm.layers:
            out = qm.tensors[l.output]
            ins = [qm.tensors[i] for i in l.inputs]
            if l.type in (LayerType.UPSAMPLE, LayerType.CONCAT):  # same quantisation (concat: shared)
                for t in ins:
                    self.assertEqual((f32(t.scale), t.zero_point), (f32(out.scale), out.zero_point))
            if l.type in (LayerType.CONV2D, LayerType.DEPTHWISE_CONV2D, LayerType.POINTWISE_CONV2D):
                self.assertTrue(np.all(np.abs(l.weights.astype(np.int32)) <= 127))
                self.assertTrue(np.all(np.abs(l.bias.astype(np.int64)) <= MAX_ABS_BIAS))
                # Per-channel symmetric: some weight of each channel reaches +-127.
                w = l.weights.reshape(len(l.bias), -1)
                self.assertTrue(np.all(np.abs(w.astype(np.int32)).max(axis=1) == 127))
                if l.act == Activation.RELU6:
                    self.assertEqual(out.zero_point, -128)  # range [0, <= 6]
                    self.assertEqual((l.out_min, l.out_max),
                                     (-128, min(127, -128 + int(np.floor(6.0 / f32(out.scale) + 0.5)))))


class QuantisationRules(unittest.TestCase):
    def test_qparams(self):
        s, z = qparams(0.0, 6.0)
        self.assertEqual((s, z), (f32(6.0 / 255.0), -128))
        s, z = qparams(-3.0, 0.0)
        self.assertEqual(z, 127)
        s, z = qparams(0.5, 2.0)  # the range always holds 0 (exact zero padding)
        self.assertEqual(z, -128)
        s, z = qparams(-1.0, 3.0)
        self.assertAlmostEqual(s * (-128 - z), -1.0, delta=s)
        self.assertAlmostEqual(s * (127 - z), 3.0, delta=s)

    def test_out_range_folds_activations_as_the_doc_says(self):
        s, z = f32(0.05), -100
        self.assertEqual(out_range((-graph.INF, graph.INF), s, z), (-128, 127))
        self.assertEqual(out_range((0.0, graph.INF), s, z), (-100, 127))
        self.assertEqual(out_range((0.0, 6.0), s, z), (-100, 20))  # z + round(6 / 0.05) = -100 + 120
        self.assertEqual(out_range((0.0, 6.0), f32(0.01), -128), (-128, 127))
        self.assertEqual(out_range((-1.0, 1.0), s, z), (-120, -80))

    def test_conv_weights_and_bias(self):
        w = np.array([[0.5, -1.0, 0.25], [0.0, 0.0, 0.0], [1e-3, 2e-3, -4e-3]], np.float32)
        b = np.array([0.1, 0.3, 1e6], np.float32)
        scales, bias, q = quantize_conv(w, b, 0.02, 0.05)
        q = q.reshape(3, 3)
        self.assertEqual(scales[0], f32(1.0 / 127.0))
        np.testing.assert_array_equal(q[0], [64, -127, 32])  # scale = float32(1/127), a hair below: 63.5000002 -> 64, 31.75 -> 32
        np.testing.assert_array_equal(q[1], [0, 0, 0])
        self.assertTrue(np.all(np.abs(bias.astype(np.int64)) <= MAX_ABS_BIAS))
        # A bias too large for the weight scale: the scale grows instead of the bias overflowing.
        self.assertGreater(scales[2], f32(4e-3 / 127))
        self.assertLessEqual(abs(int(bias[2])), MAX_ABS_BIAS)
        for o in range(3):
            self.assertIsNotNone(make_multiplier(conv_real_multiplier(0.02, scales[o], 0.05)))

    def test_ties_of_clamp_and_max_pool_and_requantising_concat(self):
        torch.manual_seed(2)
        module = OtherOps().eval()
        randomise_bn(module, 2)
        g = from_module(module, (20, 24, 4), [127.5, 127.5, 127.5, 3.0], [1 / 127.5, 1 / 127.5, 1 / 127.5, 1 / 3],
                        [f"c{i}" for i in range(6)], name="other")
        raw = np.random.RandomState(1).uniform(0, 1, size=(4, 20, 24, 4)).astype(np.float32) * \
            np.float32([255, 255, 255, 6])
        for policy in ("share", "requantize"):
            qm = quantize(g, raw, concat_policy=policy)
            types = [l.type for l in qm.layers]
            self.assertIn(LayerType.CLAMP, types)  # hardtanh after a pool stays a layer
            for l in qm.layers:
                if l.type in (LayerType.CLAMP, LayerType.MAX_POOL):
                    a, b = qm.tensors[l.inputs[0]], qm.tensors[l.output]
                    self.assertEqual((f32(a.scale), a.zero_point), (f32(b.scale), b.zero_point))
                if l.type == LayerType.CONCAT:
                    ms = [ratio_real_multiplier(qm.tensors[i].scale, qm.tensors[l.output].scale) for i in l.inputs]
                    if policy == "share":
                        self.assertTrue(all(m == 1.0 for m in ms))
            x = raw[0]
            probs, _ = int8_ref.run(qm, int8_ref.quantize_input(x, qm))
            want = graph.forward(g, graph.normalise(g, x[None]))[0]
            self.assertLess(np.abs(probs - want).mean(), 0.03, policy)


if __name__ == "__main__":
    unittest.main()
