"""ONNX import: our network exported with torch.onnx gives the IR of the PyTorch path; other
operators import correctly; unsupported ones are reported by node; the command line calibrates."""
import io
import os
import subprocess
import sys
import tempfile
import unittest
import warnings

import numpy as np
import onnx
import torch
from onnx import TensorProto, helper, numpy_helper

from edgefusion_models import efm, graph, import_onnx
from edgefusion_models.calibration import find_edgefusion
from edgefusion_models.from_onnx import from_onnx
from edgefusion_models.graph import UnsupportedModelError

from .helpers import REPO_ROOT, random_net, random_net_graph
from .test_from_torch import OtherOps, randomise_bn, torch_forward


def to_onnx(module, shape, opset, keep_bn=False):
    f = io.BytesIO()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(module, torch.zeros(shape), f, opset_version=opset, input_names=["image"],
                          output_names=["out"],
                          training=torch.onnx.TrainingMode.PRESERVE if keep_bn else torch.onnx.TrainingMode.EVAL)
    return onnx.load_from_string(f.getvalue())


def conv_sigmoid_model(extra_nodes=(), opset=13):
    """image (1x4x8x8) -> Conv 1x1 -> [extra nodes] ; initializers W, B."""
    w = numpy_helper.from_array(np.ones((4, 4, 1, 1), np.float32), "W")
    b = numpy_helper.from_array(np.zeros(4, np.float32), "B")
    nodes = [helper.make_node("Conv", ["image", "W", "B"], ["c"], name="conv0")] + list(extra_nodes)
    last = nodes[-1].output[0]
    g = helper.make_graph(nodes, "t", [helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 4, 8, 8])],
                          [helper.make_tensor_value_info(last, TensorProto.FLOAT, None)], [w, b])
    return helper.make_model(g, opset_imports=[helper.make_opsetid("", opset)])


class OnnxImportTest(unittest.TestCase):
    def test_edgesegnet_matches_the_torch_path(self):
        model, raw = random_net()
        g_torch = random_net_graph()
        x = graph.normalise(g_torch, raw[:1])
        want = graph.forward(g_torch, x, keep=True)
        logits = g_torch.nodes[-1].inputs[0]
        for opset, keep_bn in ((11, False), (13, True)):
            g = from_onnx(to_onnx(model, (1, 4, 120, 160), opset, keep_bn))
            self.assertEqual([n.kind for n in g.nodes], [n.kind for n in g_torch.nodes])
            self.assertEqual([(n.kernel, n.stride, n.dilation, n.pads, n.act_range, n.factor, n.mode) for n in g.nodes],
                             [(n.kernel, n.stride, n.dilation, n.pads, n.act_range, n.factor, n.mode)
                              for n in g_torch.nodes])
            self.assertEqual(g.class_names, g_torch.class_names)
            got = graph.forward(g, x, keep=True)
            np.testing.assert_allclose(got[g.nodes[-1].inputs[0]], want[logits], rtol=0, atol=1e-4,
                                       err_msg=f"opset {opset}")
            np.testing.assert_allclose(got[g.output], want[g_torch.output], rtol=0, atol=1e-5)

    def test_other_operators(self):
        torch.manual_seed(7)
        module = OtherOps().eval()
        randomise_bn(module, 7)
        g = from_onnx(to_onnx(module, (1, 4, 20, 24), 13, keep_bn=True), class_names=[f"c{i}" for i in range(6)])
        kinds = [n.kind for n in g.nodes]
        for k in ("conv2d", "depthwise_conv2d", "pointwise_conv2d", "add", "clamp", "max_pool", "avg_pool",
                  "upsample", "concat", "softmax"):
            self.assertIn(k, kinds)
        self.assertEqual(kinds.count("softmax"), 1)  # the model's own softmax is the output stage
        x = np.random.RandomState(0).normal(size=(1, 20, 24, 4)).astype(np.float32)
        np.testing.assert_allclose(graph.forward(g, x), torch_forward(module, x), rtol=0, atol=1e-5)

    def test_unsupported_operators_are_named(self):
        m = conv_sigmoid_model([helper.make_node("Sigmoid", ["c"], ["s"], name="gate"),
                                helper.make_node("Mul", ["s", "c"], ["y"], name="scale_by_gate")])
        with self.assertRaises(UnsupportedModelError) as cm:
            from_onnx(m, class_names=["a", "b", "c", "d"])
        msg = str(cm.exception)
        self.assertIn("node 'gate' (Sigmoid): no sigmoid layer", msg)
        self.assertIn("node 'scale_by_gate' (Mul): no elementwise multiplication", msg)

    def test_missing_and_garbage_files_are_named_without_a_traceback(self):
        # Issue 33, rough edge 6: a clear line naming the file and exit status 2, no Python traceback.
        with tempfile.TemporaryDirectory() as d:
            garbage = os.path.join(d, "garbage.onnx")
            with open(garbage, "wb") as f:
                f.write(b"this is not a protobuf\n" * 10)
            for path, says in ((os.path.join(d, "missing.onnx"), "no such file"),
                               (garbage, "not a readable ONNX model")):
                err = io.StringIO()
                old, sys.stderr = sys.stderr, err
                try:
                    code = import_onnx.main(["--onnx", path, "--calibration", "npz:none.npz",
                                             "--out", os.path.join(d, "m.efm")])
                finally:
                    sys.stderr = old
                self.assertEqual(code, 2, err.getvalue())
                self.assertIn(path, err.getvalue())
                self.assertIn(says, err.getvalue())
                self.assertNotIn("Traceback", err.getvalue())
                self.assertFalse(os.path.exists(os.path.join(d, "m.efm")))

    def test_opset10_clip_attributes_and_resize(self):
        scales = numpy_helper.from_array(np.array([1, 1, 2, 2], np.float32), "sc")
        m = conv_sigmoid_model([helper.make_node("Clip", ["c"], ["r"], name="relu6", min=0.0, max=6.0),
                                helper.make_node("Constant", [], ["scales"], value=scales),
                                helper.make_node("Resize", ["r", "scales"], ["up"], name="up", mode="nearest")],
                               opset=10)
        g = from_onnx(m, class_names=["a", "b", "c", "d"])
        self.assertEqual([n.kind for n in g.nodes], ["pointwise_conv2d", "upsample", "softmax"])
        self.assertEqual(g.nodes[0].act_range, (0.0, 6.0))
        self.assertEqual((g.nodes[1].factor, g.nodes[1].mode), (2, "nearest"))
        m = conv_sigmoid_model([helper.make_node("Constant", [], ["scales"], value=scales),
                                helper.make_node("Resize", ["c", "scales"], ["up"], name="up", mode="linear")],
                               opset=10)
        with self.assertRaisesRegex(UnsupportedModelError, r"'up' \(Resize\): linear with "
                                                           r"coordinate_transformation_mode=asymmetric"):
            from_onnx(m, class_names=["a", "b", "c", "d"])

    def test_unsupported_attributes_are_named(self):
        cases = [
            (conv_sigmoid_model([helper.make_node("Softmax", ["c"], ["p"], name="sm", axis=1)], opset=11),
             r"'sm' \(Softmax\): opset 11 Softmax normalises over everything after axis 1"),
            (conv_sigmoid_model([helper.make_node("Concat", ["c", "c"], ["k"], name="cat", axis=2)]),
             r"'cat' \(Concat\): axis 2"),
            (conv_sigmoid_model([helper.make_node("MaxPool", ["c"], ["p"], name="mp", kernel_shape=[2, 2],
                                                  dilations=[2, 2])]), r"'mp' \(MaxPool\): dilated pooling"),
            (conv_sigmoid_model([helper.make_node("Constant", [], ["k"], value=numpy_helper.from_array(
                np.ones((1, 4, 1, 1), np.float32))), helper.make_node("Add", ["c", "k"], ["y"], name="bias_add")]),
             r"'bias_add' \(Add\): operand 'k' is a constant"),
            (conv_sigmoid_model([helper.make_node("BatchNormalization", ["image", "W", "B", "B", "B"], ["y"],
                                                  name="bn_first")]), r"'bn_first' \(BatchNormalization\)"),
        ]
        for model, pattern in cases:
            with self.assertRaisesRegex(UnsupportedModelError, pattern):
                from_onnx(model, class_names=["a", "b", "c", "d"])

    def test_importer_needs_no_torch(self):
        # `edgefusion model import` promises python3-onnx, numpy and opencv only.
        from edgefusion_models import net, netconst
        for name in netconst.NAMES:
            self.assertEqual(getattr(netconst, name), getattr(net, name), name)
        code = "import sys, edgefusion_models.import_onnx; sys.exit('torch' in sys.modules)"
        env = dict(os.environ, PYTHONPATH=os.path.join(REPO_ROOT, "models"))
        self.assertEqual(subprocess.run([sys.executable, "-c", code], env=env).returncode, 0)

    def test_command_line_with_npz_calibration(self):
        model, raw = random_net()
        with tempfile.TemporaryDirectory() as tmp:
            onnx.save(to_onnx(model, (1, 4, 120, 160), 13), os.path.join(tmp, "net.onnx"))
            np.savez(os.path.join(tmp, "calib.npz"), rgb=raw[..., :3].astype(np.uint8), depth=raw[..., 3])
            rc = import_onnx.main(["--onnx", os.path.join(tmp, "net.onnx"), "--calibration",
                                   "npz:" + os.path.join(tmp, "calib.npz"), "--out", os.path.join(tmp, "m.efm"),
                                   "--frames", "2", "--golden-dir", os.path.join(tmp, "golden"), "--quiet"])
            self.assertEqual(rc, 0)
            m = efm.read(os.path.join(tmp, "m.efm"))
            self.assertEqual(len(m.layers), 26)
            self.assertTrue(os.path.exists(os.path.join(tmp, "golden", "manifest.txt")))
            # Unsupported models: exit status 2 and the reason, no file.
            onnx.save(conv_sigmoid_model([helper.make_node("Sigmoid", ["c"], ["s"], name="gate")]),
                      os.path.join(tmp, "bad.onnx"))
            rc = import_onnx.main(["--onnx", os.path.join(tmp, "bad.onnx"), "--calibration", "npz:x.npz",
                                   "--out", os.path.join(tmp, "bad.efm")])
            self.assertEqual(rc, 2)
            self.assertFalse(os.path.exists(os.path.join(tmp, "bad.efm")))

    def test_command_line_with_an_edgefusion_source(self):
        try:
            binary = find_edgefusion()
        except FileNotFoundError:
            self.skipTest("no edgefusion binary (build the app, or set EDGEFUSION)")
        model, _ = random_net()
        with tempfile.TemporaryDirectory() as tmp:
            onnx.save(to_onnx(model, (1, 4, 120, 160), 11), os.path.join(tmp, "net.onnx"))
            rc = import_onnx.main(["--onnx", os.path.join(tmp, "net.onnx"), "--calibration",
                                   "synthetic:random?seed=9001&frames=3&size=160x120", "--frames", "3",
                                   "--edgefusion", binary, "--out", os.path.join(tmp, "m.efm"), "--quiet"])
            self.assertEqual(rc, 0)
            self.assertEqual(efm.read(os.path.join(tmp, "m.efm")).tensors[0].shape, (120, 160, 4))


if __name__ == "__main__":
    unittest.main()
