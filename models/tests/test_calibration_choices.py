"""The TFLite importer's calibration choices (issue 28): activation ranges clipped to their least
squared error, the bias correction's per-channel gain, the integer input mean, and calibration frames
that keep away from the frames the agreement is measured on."""
import copy
import unittest

import numpy as np

from edgefusion_models import calibration, graph, int8_ref
from edgefusion_models.graph import INF, Graph, Node
from edgefusion_models.qmodel import f32
from edgefusion_models.quantize import (GAIN_LIMIT, HISTOGRAM_BINS, _fake_quant, activation_params, calibrate,
                                        correct_biases, input_range, integer_input_mean, mse_clip, qparams,
                                        quantize_conv, quantize_graph)

from .helpers import random_net, random_net_graph


def fake_quant_mse(v, lo, hi):
    s, z = qparams(lo, hi, round_ends=False)
    return float(np.mean((_fake_quant(v, s, z).astype(np.float64) - v) ** 2))


def clip_of(v):
    lo, hi = min(float(v.min()), 0.0), max(float(v.max()), 0.0)
    counts, edges = np.histogram(v, bins=HISTOGRAM_BINS, range=(lo, hi))
    return mse_clip(counts, edges), (lo, hi)


def rgb_graph(seed=0, size=(17, 21)):
    """A small RGB network read as DeepLab's: (v - 127.5) / 127.5, a 3x3 stride-2 stem with zero
    padding and ReLU6, a 1x1 and a softmax."""
    rng = np.random.RandomState(seed)
    h, w = size
    stem = Node("stem", "conv2d", ["x"], "a", weight=rng.normal(0, 0.3, (8, 3, 3, 3)).astype(np.float32),
                bias=rng.normal(0, 0.1, 8).astype(np.float32), kernel=(3, 3), stride=(2, 2), pads=(1, 1, 1, 1),
                act_range=(0.0, 6.0))
    head = Node("head", "pointwise_conv2d", ["a"], "b", weight=rng.normal(0, 0.5, (5, 8)).astype(np.float32),
                bias=np.zeros(5, np.float32))
    soft = Node("soft", "softmax", ["b"], "p")
    return Graph(name="rgb", input="x", input_shape=(h, w, 3), output="p", nodes=[stem, head, soft],
                 mean=[127.5] * 3, scale=[1.0 / 127.5] * 3)


class MseClip(unittest.TestCase):
    def test_a_heavy_tail_is_clipped_and_the_error_falls(self):
        rng = np.random.RandomState(1)
        # After a ReLU: one end at 0, a long tail and two outliers.
        v = np.concatenate([np.abs(rng.laplace(0, 1, 200000)), [40.0, 45.0]]).astype(np.float32)
        (lo, hi), (_, o_hi) = clip_of(v)
        self.assertEqual(lo, 0.0)
        self.assertLess(hi, 0.9 * o_hi)
        # On the values themselves (not the histogram): the clip's int8 error is below min/max's.
        self.assertLess(fake_quant_mse(v, lo, hi), 0.9 * fake_quant_mse(v, 0.0, o_hi))
        # Both ends: each moves inside, and the error falls.
        v = np.concatenate([rng.laplace(0, 1, 200000), [-40.0, 45.0]]).astype(np.float32)
        (lo, hi), (o_lo, o_hi) = clip_of(v)
        self.assertTrue(o_lo < lo < 0.0 < hi < o_hi)
        self.assertLess(fake_quant_mse(v, lo, hi), 0.8 * fake_quant_mse(v, o_lo, o_hi))

    def test_a_uniform_range_is_kept(self):
        v = np.random.RandomState(2).uniform(0, 6, 100000).astype(np.float32)
        (lo, hi), (_, o_hi) = clip_of(v)
        self.assertEqual(lo, 0.0)
        self.assertGreaterEqual(hi, 0.97 * o_hi)
        self.assertLessEqual(hi, o_hi)

    def test_calibrated_ranges_lie_inside_the_observed_ones(self):
        g = random_net_graph()
        raw = random_net()[1]
        in_range = input_range(g)
        mm = calibrate(g, raw, in_range)
        clipped = calibrate(g, raw, in_range, clip="mse")
        self.assertEqual(set(mm), set(clipped))
        self.assertEqual(clipped[g.input], mm[g.input])
        narrower = 0
        for t, (lo, hi) in clipped.items():
            self.assertGreaterEqual(lo, min(mm[t][0], 0.0) - 1e-6, t)
            self.assertLessEqual(hi, max(mm[t][1], 0.0) + 1e-6, t)
            narrower += (hi - lo) < (max(mm[t][1], 0.0) - min(mm[t][0], 0.0)) * 0.999
        self.assertGreater(narrower, 0)
        with self.assertRaises(ValueError):
            calibrate(g, raw, in_range, clip="percentile")


class GainCorrection(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        # The random EdgeSegNet with its weights put on a per-channel int8 grid, as imported int8
        # weights are (Node.weight_scale).
        g = copy.deepcopy(random_net_graph())
        for n in g.nodes:
            if n.kind in graph.CONV_KINDS:
                w = n.weight.reshape(n.weight.shape[0], -1).astype(np.float64)
                grid = np.maximum(np.abs(w).max(axis=1), 1e-6) / 127.0
                n.weight = (np.rint(w / grid[:, None]) * grid[:, None]).reshape(n.weight.shape).astype(np.float32)
                n.weight_scale = grid.astype(np.float32)
        cls.g0 = g
        cls.raw = random_net()[1]
        cls.ranges = calibrate(g, cls.raw, input_range(g), clip="mse")
        cls.g = copy.deepcopy(g)
        cls.gains = correct_biases(cls.g, cls.raw, cls.ranges, gain=True)

    def test_integers_are_kept_and_only_scales_move(self):
        params = activation_params(self.g0, self.ranges, input_range(self.g0))
        convs = [n for n in self.g0.nodes if n.kind in graph.CONV_KINDS]
        self.assertEqual(set(self.gains), {n.name for n in convs})
        after = {n.name: n for n in self.g.nodes}
        moved = 0
        for n in convs:
            m = after[n.name]
            s_in, s_out = params[n.inputs[0]][0], params[n.output][0]
            sc0, _, q0 = quantize_conv(n.weight, n.bias, s_in, s_out, n.weight_scale)
            sc1, _, q1 = quantize_conv(m.weight, m.bias, s_in, s_out, m.weight_scale)
            np.testing.assert_array_equal(q0, q1, err_msg=n.name)
            a = self.gains[n.name]
            self.assertTrue(np.all(np.abs(a - 1.0) <= GAIN_LIMIT + 1e-9), n.name)
            np.testing.assert_allclose(sc1, sc0 * a, rtol=1e-6, err_msg=n.name)
            moved += int(np.sum(np.abs(a - 1.0) > 1e-4))
        self.assertGreater(moved, 0)

    def test_first_layer_int8_output_has_the_float_mean_and_spread(self):
        # The first convolution's only quantised input is the frame: after the correction its
        # simulated int8 pre-activation output has the float one's mean and standard deviation per
        # channel (where the gain was not limited).
        g0, g = self.g0, self.g
        n0, n1 = g0.nodes[0], g.nodes[0]
        params = activation_params(g, self.ranges, input_range(g))
        in_range = input_range(g)
        x = np.clip(graph.normalise(g, self.raw), np.float32(in_range[0]), np.float32(in_range[1]))
        lin0 = Node(**{**n0.__dict__, "act_range": (-INF, INF)})
        f_pre = graph.run_node(lin0, [x]).reshape(-1, n0.weight.shape[0]).astype(np.float64)
        sc, _, qw = quantize_conv(n1.weight, n1.bias, params[g.input][0], params[n1.output][0], n1.weight_scale)
        lin1 = Node(**{**n1.__dict__, "act_range": (-INF, INF)})
        lin1.weight = (qw.reshape(n1.weight.shape[0], -1) * sc[:, None].astype(np.float64)).reshape(
            n1.weight.shape).astype(np.float32)
        q_pre = graph.run_node(lin1, [_fake_quant(x, *params[g.input])]).reshape(f_pre.shape).astype(np.float64)
        free = np.abs(self.gains[n1.name] - 1.0) < GAIN_LIMIT - 1e-6
        self.assertGreater(int(free.sum()), 0)
        np.testing.assert_allclose(q_pre.mean(0), f_pre.mean(0), atol=1e-4 * float(f_pre.std()))
        np.testing.assert_allclose(q_pre.std(0)[free], f_pre.std(0)[free], rtol=1e-3)


class IntegerInputMean(unittest.TestCase):
    def test_the_int8_input_is_exact_and_the_network_unchanged_inside(self):
        g0 = rgb_graph()
        g = integer_input_mean(copy.deepcopy(g0))
        self.assertEqual(g.mean, [128.0] * 3)
        raw = np.random.RandomState(5).randint(0, 256, (2, 17, 21, 3)).astype(np.float32)
        qm = quantize_graph(g, calibrate(g, raw, input_range(g)))
        t_in = qm.tensors[qm.input_tensor]
        self.assertEqual(np.float32(t_in.scale), np.float32(1.0 / 127.5))
        self.assertEqual(t_in.zero_point, 0)
        v = np.arange(256, dtype=np.float32)
        q = int8_ref.quantize_input(np.repeat(v[:, None, None], 3, axis=2), qm)
        np.testing.assert_array_equal(q[:, 0, 0].astype(np.int32), np.arange(256) - 128)
        # The float network: the same away from the stem's zero padding, nearly the same on it.
        a0 = graph.forward(g0, graph.normalise(g0, raw), keep=True)["a"]
        a1 = graph.forward(g, graph.normalise(g, raw), keep=True)["a"]
        # (the stem's windows overlap its padding in the first and the last row and column)
        np.testing.assert_allclose(a1[:, 1:-1, 1:-1], a0[:, 1:-1, 1:-1], atol=1e-5)
        self.assertLess(float(np.abs(a1 - a0).max()), 0.05)

    def test_what_it_leaves_alone(self):
        g = rgb_graph()
        g.mean = [128.0] * 3
        b = g.nodes[0].bias.copy()
        integer_input_mean(g)
        np.testing.assert_array_equal(g.nodes[0].bias, b)
        g = copy.deepcopy(random_net_graph())  # RGB-D: R, G, B and depth means as they were (127.5, 3)
        before = list(g.mean)
        integer_input_mean(g)
        self.assertEqual(g.mean[3], before[3])


class CentredFrames(unittest.TestCase):
    def test_middle_frames_of_equal_segments(self):
        np.testing.assert_array_equal(calibration.evenly_spaced(1000, 100, centred=True), np.arange(5, 1000, 10))
        forty = calibration.evenly_spaced(1000, 40, centred=True)
        self.assertEqual(len(forty), 40)
        self.assertEqual(list(forty[:3]), [12, 37, 62])
        self.assertFalse(np.any(forty % 10 == 0))  # never one of the frames every 10th from the first
        np.testing.assert_array_equal(calibration.evenly_spaced(10, 40, centred=True), np.arange(10))
        # The default is what it was: both ends and evenly between.
        np.testing.assert_array_equal(calibration.evenly_spaced(1000, 3), [0, 500, 999])


if __name__ == "__main__":
    unittest.main()
