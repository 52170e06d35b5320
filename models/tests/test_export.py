"""The export command line on a train.py-style checkpoint and calibration .npz."""
import contextlib
import os
import tempfile
import unittest

import numpy as np
import torch

from edgefusion_models import efm, export, golden, int8_ref

from .helpers import random_net


class ExportTest(unittest.TestCase):
    def test_checkpoint_export_writes_a_valid_model_and_golden(self):
        model, raw = random_net()
        with tempfile.TemporaryDirectory() as tmp:
            torch.save({"model": model.state_dict(), "epoch": 3}, os.path.join(tmp, "ckpt.pt"))
            n = len(raw)
            np.savez(os.path.join(tmp, "val.npz"), rgb=raw[..., :3].astype(np.uint8), depth=raw[..., 3],
                     labels=np.zeros(raw.shape[:3], np.uint8))
            out, gdir = os.path.join(tmp, "seg.efm"), os.path.join(tmp, "golden")
            rc = export.main(["--checkpoint", os.path.join(tmp, "ckpt.pt"), "--calibration-npz",
                              os.path.join(tmp, "val.npz"), "--out", out, "--golden-dir", gdir,
                              "--max-calibration", str(n), "--golden-frame", "1", "--quiet"])
            self.assertEqual(rc, 0)
            m = efm.read(out)
            self.assertEqual(m.name, "edgesegnet")
            self.assertEqual(len(m.class_names), 14)
            man = golden.read_manifest(gdir)
            self.assertIn("calibrated on 3 frames of val.npz; golden input = calibration frame 1",
                          " ".join(man["description"]))
            x = np.fromfile(os.path.join(gdir, golden.INPUT_FILE), np.int8).reshape(120, 160, 4)
            # The golden input is frame 1 quantised by the model's own input quantisation (3.1).
            np.testing.assert_array_equal(x, int8_ref.quantize_input(raw[1], m))
            probs, _ = int8_ref.run(m, x)
            self.assertEqual(int(man["output"][4], 16), golden.crc32(probs.astype("<f4")))
            with open(out, "rb") as f:
                self.assertEqual(int(man["model_crc32"][0], 16), golden.crc32(f.read()))

    def test_missing_calibration_is_an_error(self):
        with self.assertRaises(SystemExit):
            with open(os.devnull, "w") as devnull, contextlib.redirect_stderr(devnull):
                export.main(["--checkpoint", "x.pt", "--out", "y.efm"])


if __name__ == "__main__":
    unittest.main()
