"""The committed C++ fixture (tests/data/nn/random_edgesegnet/) is what the exporter makes today:
re-running `export --random-init 1` reproduces every byte, and the integer reference reproduces the
manifest's checksums. When an intended change to the exporter breaks this, regenerate the fixture:
    cd models && /usr/bin/python3 -m edgefusion_models.export --random-init 1 \\
        --out ../tests/data/nn/random_edgesegnet/model.efm --golden-dir ../tests/data/nn/random_edgesegnet
and run the C++ test (test_nn --gtest_filter='NnGolden.*')."""
import os
import tempfile
import unittest

import numpy as np

from edgefusion_models import efm, export, golden, int8_ref

from .helpers import FIXTURE_DIR

FIXTURE_FILES = ("model.efm", golden.INPUT_FILE, golden.ROWS_FILE, golden.MANIFEST)


class DeterminismTest(unittest.TestCase):
    def test_export_reproduces_the_committed_fixture(self):
        with tempfile.TemporaryDirectory() as tmp:
            rc = export.main(["--random-init", "1", "--out", os.path.join(tmp, "model.efm"), "--golden-dir", tmp,
                              "--quiet"])
            self.assertEqual(rc, 0)
            for name in FIXTURE_FILES:
                with open(os.path.join(tmp, name), "rb") as f:
                    new = f.read()
                with open(os.path.join(FIXTURE_DIR, name), "rb") as f:
                    committed = f.read()
                self.assertTrue(new == committed, f"{name} differs from the committed fixture (see this file's docstring)")

    def test_fixture_is_small(self):
        total = sum(os.path.getsize(os.path.join(FIXTURE_DIR, n)) for n in FIXTURE_FILES)
        self.assertLess(total, 400 * 1024)

    def test_manifest_matches_the_integer_reference(self):
        m = efm.read(os.path.join(FIXTURE_DIR, "model.efm"))
        man = golden.read_manifest(FIXTURE_DIR)
        x = np.fromfile(os.path.join(FIXTURE_DIR, golden.INPUT_FILE), np.int8)
        probs, tensors = int8_ref.run(m, x, keep_tensors=True)
        self.assertEqual(int(man["output"][4], 16), golden.crc32(probs.astype("<f4")))
        for tid, rec in man["tensors"].items():
            self.assertEqual(int(rec[4], 16), golden.crc32(tensors[tid]), f"tensor {tid}")
        rows = np.fromfile(os.path.join(FIXTURE_DIR, golden.ROWS_FILE), "<f4").reshape(-1, *probs.shape[1:])
        np.testing.assert_array_equal(rows, probs[[int(r) for r in man["rows"][1:]]])


if __name__ == "__main__":
    unittest.main()
