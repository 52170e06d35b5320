"""PyTorch -> IR: the IR's numpy float forward pass equals PyTorch's."""
import unittest

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

from edgefusion_models import graph
from edgefusion_models.from_torch import from_module
from edgefusion_models.graph import UnsupportedModelError

from .helpers import random_net, random_net_graph


def torch_forward(module, x_nhwc):
    with torch.no_grad():
        return module(torch.from_numpy(x_nhwc.transpose(0, 3, 1, 2).copy())).numpy().transpose(0, 2, 3, 1)


class OtherOps(nn.Module):
    """Every importable operator that EdgeSegNet does not use."""

    def __init__(self):
        super().__init__()
        self.c1 = nn.Conv2d(4, 8, 5, stride=2, padding=2, bias=True)
        self.bn1 = nn.BatchNorm2d(8)
        self.dw = nn.Conv2d(8, 8, 3, padding=2, dilation=2, groups=8, bias=False)
        self.bn2 = nn.BatchNorm2d(8)
        self.pw = nn.Conv2d(8, 8, 1)
        self.pool = nn.MaxPool2d(3, stride=2, padding=1)
        self.avg = nn.AvgPool2d(3, stride=1, padding=1, count_include_pad=False)
        self.up = nn.Upsample(scale_factor=2, mode="nearest")
        self.same = nn.Conv2d(16, 6, 3, padding=1)
        self.act = nn.Hardtanh(-1.0, 2.0)

    def forward(self, x):
        a = F.relu(self.bn1(self.c1(x)))
        b = F.relu6(self.bn2(self.dw(a)))
        s = self.pw(b) + a                                     # residual add, no activation
        p = self.avg(self.pool(torch.relu(s)))
        u = self.up(p)
        v = F.interpolate(self.act(p), scale_factor=2, mode="bilinear", align_corners=False)
        y = self.same(torch.cat([u, v], dim=1))
        return F.softmax(y.clamp(-4.0, 4.0), dim=1)


def randomise_bn(module, seed):
    g = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        for m in module.modules():
            if isinstance(m, nn.BatchNorm2d):
                m.running_mean.uniform_(-0.5, 0.5, generator=g)
                m.running_var.uniform_(0.3, 2.0, generator=g)
                m.weight.uniform_(0.5, 1.5, generator=g)
                m.bias.uniform_(-0.5, 0.5, generator=g)


class FromTorchTest(unittest.TestCase):
    def test_edgesegnet_float_forward_equals_torch(self):
        model, raw = random_net()
        g = random_net_graph()
        x = graph.normalise(g, raw[:2])
        vals = graph.forward(g, x, keep=True)
        logits = vals[g.nodes[-1].inputs[0]]
        want = torch_forward(model, x)
        self.assertGreater(np.abs(want).max(), 1.0)  # non-trivial logits
        np.testing.assert_allclose(logits, want, rtol=0, atol=1e-4)
        p = torch.softmax(torch.from_numpy(want), dim=3).numpy()
        np.testing.assert_allclose(vals[g.output], p, rtol=0, atol=1e-5)

    def test_edgesegnet_structure(self):
        g = random_net_graph()
        kinds = [n.kind for n in g.nodes]
        self.assertEqual(sum(k in ("conv2d", "depthwise_conv2d", "pointwise_conv2d") for k in kinds), 20)
        self.assertEqual(kinds.count("upsample"), 3)
        self.assertEqual(kinds.count("concat"), 2)
        self.assertEqual(kinds[-1], "softmax")
        self.assertNotIn("batchnorm", kinds)
        self.assertNotIn("clamp", kinds)  # every ReLU6 folded into its convolution
        ranged = [n for n in g.nodes if n.kind.endswith("conv2d")]
        self.assertTrue(all(n.act_range == (0.0, 6.0) for n in ranged[:-1]))
        self.assertEqual(ranged[-1].act_range, (-graph.INF, graph.INF))  # the classifier: logits
        self.assertTrue(all(n.mode == "bilinear" and n.factor == 2 for n in g.nodes if n.kind == "upsample"))
        self.assertEqual(graph.infer_shapes(g)[g.output], (120, 160, 14))

    def test_other_operators(self):
        torch.manual_seed(5)
        module = OtherOps().eval()
        randomise_bn(module, 5)
        g = from_module(module, (20, 24, 4), [0.0] * 4, [1.0] * 4, [f"c{i}" for i in range(6)], name="other")
        kinds = [n.kind for n in g.nodes]
        for k in ("conv2d", "depthwise_conv2d", "pointwise_conv2d", "add", "clamp", "max_pool", "avg_pool",
                  "upsample", "concat", "softmax"):
            self.assertIn(k, kinds)
        x = np.random.RandomState(0).normal(size=(2, 20, 24, 4)).astype(np.float32)
        np.testing.assert_allclose(graph.forward(g, x), torch_forward(module, x), rtol=0, atol=1e-5)

    def test_same_padding(self):
        module = nn.Sequential(nn.Conv2d(4, 3, 4, padding="same")).eval()  # pads 1 before, 2 after
        g = from_module(module, (7, 9, 4), [0.0] * 4, [1.0] * 4)
        self.assertEqual(g.nodes[0].pads, (1, 1, 2, 2))
        x = np.random.RandomState(3).normal(size=(1, 7, 9, 4)).astype(np.float32)
        vals = graph.forward(g, x, keep=True)
        np.testing.assert_allclose(vals[g.nodes[0].output], torch_forward(module, x), rtol=0, atol=1e-5)

    def test_unsupported_operator_is_named(self):
        class Sig(nn.Module):
            def __init__(self):
                super().__init__()
                self.conv = nn.Conv2d(4, 4, 1)

            def forward(self, x):
                return torch.sigmoid(self.conv(x))

        with self.assertRaisesRegex(UnsupportedModelError, "node 'sigmoid'.*not supported"):
            from_module(Sig().eval(), (4, 4, 4), [0.0] * 4, [1.0] * 4)

        class Grouped(nn.Module):
            def __init__(self):
                super().__init__()
                self.conv = nn.Conv2d(4, 8, 3, groups=2)

            def forward(self, x):
                return self.conv(x)

        with self.assertRaisesRegex(UnsupportedModelError, "node 'conv'.*grouped convolution with 2 groups"):
            from_module(Grouped().eval(), (6, 6, 4), [0.0] * 4, [1.0] * 4)


if __name__ == "__main__":
    unittest.main()
