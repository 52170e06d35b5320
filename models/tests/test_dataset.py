"""The training data's sequences: which URI each seed gets, and that the Kinect-like camera changes
the colour images only (the network's targets and depth input stay those of the ideal camera)."""
import os
import tempfile
import unittest

import numpy as np

from edgefusion_models import dataset
from edgefusion_models.calibration import find_edgefusion


class SequenceUriTest(unittest.TestCase):
    def test_ideal_is_the_default_and_kinect_adds_the_camera(self):
        ideal = dataset.sequence_uri(7)
        self.assertNotIn("camera=", ideal)
        self.assertEqual(dataset.sequence_uri(7, "ideal"), ideal)
        self.assertEqual(dataset.sequence_uri(7, "kinect"), ideal + "&camera=kinect")
        # The split recipe: every third seed the robot path, every fifth without sensor noise.
        self.assertIn("trajectory=robot", dataset.sequence_uri(9))
        self.assertIn("noise=0", dataset.sequence_uri(4))
        self.assertIn(f"frames={dataset.TRAIN_FRAMES}", dataset.sequence_uri(1))
        self.assertIn(f"frames={dataset.EVAL_FRAMES}", dataset.sequence_uri(9001))

    def test_island_layout_goes_to_the_hand_held_sequences_only(self):
        walls = dataset.sequence_uri(7)
        self.assertNotIn("layout=", walls)
        self.assertEqual(dataset.sequence_uri(7, layout="walls"), walls)
        self.assertEqual(dataset.sequence_uri(7, layout="island"), walls + "&layout=island")
        self.assertEqual(dataset.sequence_uri(7, "kinect", "island"), walls + "&camera=kinect&layout=island")
        # Robot sequences keep the walls layout: on many robot paths no middle group fits.
        self.assertEqual(dataset.sequence_uri(9, layout="island"), dataset.sequence_uri(9))

    def test_inspecting_scan_goes_to_half_the_hand_held_sequences(self):
        # Seeds 7 (odd) and 8 (even) are hand-held, 9 is a robot sequence.
        for seed in (7, 8, 9):
            self.assertEqual(dataset.sequence_uri(seed, handheld="loop"), dataset.sequence_uri(seed))
        self.assertEqual(dataset.sequence_uri(7, handheld="inspect"),
                         dataset.sequence_uri(7).replace("trajectory=loop", "trajectory=inspect"))
        self.assertNotEqual(dataset.sequence_uri(7, handheld="inspect"), dataset.sequence_uri(7))
        self.assertEqual(dataset.sequence_uri(8, handheld="inspect"), dataset.sequence_uri(8))
        self.assertEqual(dataset.sequence_uri(9, handheld="inspect"), dataset.sequence_uri(9))
        # The island layout goes to the scan too (it walks the loop's path).
        self.assertEqual(dataset.sequence_uri(7, layout="island", handheld="inspect"),
                         dataset.sequence_uri(7, handheld="inspect") + "&layout=island")
        # Of the training split's hand-held sequences, about half scan.
        seeds = dataset.SPLIT_SEEDS["train"]
        uris = [dataset.sequence_uri(s, handheld="inspect") for s in seeds]
        scans = sum("trajectory=inspect" in u for u in uris)
        loops = sum("trajectory=loop" in u for u in uris)
        self.assertEqual(scans + loops + sum("trajectory=robot" in u for u in uris), len(seeds))
        self.assertEqual(scans, loops)

    def test_splits_never_share_a_seed(self):
        splits = [set(r) for r in dataset.SPLIT_SEEDS.values()]
        for i in range(len(splits)):
            for j in range(i + 1, len(splits)):
                self.assertFalse(splits[i] & splits[j])


class KinectCameraDataTest(unittest.TestCase):
    def test_kinect_camera_changes_colour_but_not_labels_or_depth(self):
        try:
            binary = find_edgefusion()
        except FileNotFoundError:
            self.skipTest("no edgefusion binary (build the app, or set EDGEFUSION)")
        with tempfile.TemporaryDirectory() as tmp:
            seed = 5  # a training seed: 14 frames, hand-held loop, sensor noise on
            ideal = dataset.load_tum_folder(dataset.render_sequence(binary, seed, os.path.join(tmp, "ideal")))
            kinect = dataset.load_tum_folder(
                dataset.render_sequence(binary, seed, os.path.join(tmp, "kinect"), camera="kinect"))
            for a, b in zip(ideal, kinect):
                self.assertEqual(a.shape, b.shape)
            self.assertEqual(ideal[0].shape, (dataset.TRAIN_FRAMES, 120, 160, 3))
            np.testing.assert_array_equal(ideal[2], kinect[2])  # labels
            np.testing.assert_array_equal(ideal[1], kinect[1])  # depth (the same depth noise)
            # The camera darkens these bright rooms (auto-exposure towards 18% grey) and adds noise.
            self.assertLess(kinect[0].mean(), ideal[0].mean() - 20)
            self.assertGreater(np.abs(kinect[0].astype(int) - ideal[0].astype(int)).mean(), 10)


if __name__ == "__main__":
    unittest.main()
