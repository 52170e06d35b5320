"""Distillation (edgefusion_models/distill.py): the loss against soft targets, the resampling and
flipping of the teacher's probabilities, the held-out split and the agreement figure."""
import unittest

import numpy as np
import torch
import torch.nn.functional as F

from edgefusion_models import distill, train


class SoftTargets(unittest.TestCase):
    def test_soft_cross_entropy_of_one_hot_targets_is_the_cross_entropy(self):
        g = torch.Generator().manual_seed(1)
        logits = torch.randn(2, 14, 5, 7, generator=g)
        labels = torch.randint(0, 14, (2, 5, 7), generator=g)
        one_hot = F.one_hot(labels, 14).permute(0, 3, 1, 2).float()
        self.assertAlmostEqual(distill.soft_cross_entropy(logits, one_hot).item(),
                               F.cross_entropy(logits, labels).item(), places=5)

    def test_soft_cross_entropy_is_least_at_the_teachers_distribution(self):
        g = torch.Generator().manual_seed(2)
        teacher_logits = torch.randn(1, 14, 4, 4, generator=g)
        target = torch.softmax(teacher_logits, 1)
        at_teacher = distill.soft_cross_entropy(teacher_logits, target).item()
        for _ in range(5):
            other = teacher_logits + 0.5 * torch.randn(1, 14, 4, 4, generator=g)
            self.assertGreater(distill.soft_cross_entropy(other, target).item(), at_teacher)

    def test_resampled_probabilities_stay_distributions(self):
        rng = np.random.default_rng(3)
        p = rng.random((2, 49, 65, 14)).astype(np.float32)
        p /= p.sum(-1, keepdims=True)
        r = distill.resample_probabilities(p, 120, 160)
        self.assertEqual(r.shape, (2, 120, 160, 14))
        np.testing.assert_allclose(r.sum(-1), 1.0, atol=1e-5)
        self.assertGreaterEqual(r.min(), 0.0)
        np.testing.assert_array_equal(distill.resample_probabilities(p, 49, 65), p)  # same size: unchanged

    def test_a_flipped_frame_has_its_targets_flipped(self):
        rng = np.random.default_rng(4)
        n, h, w = 64, 6, 8
        rgb = np.zeros((n, h, w, 3), np.uint8)
        rgb[:, :, :w // 2] = 200  # bright left half
        depth = np.ones((n, h, w), np.float32)
        probs = np.zeros((n, 3, 4, 14), np.float32)
        probs[:, :, :2, 1] = 1.0  # class 1 on the left half of the (coarser) teacher grid
        probs[:, :, 2:, 2] = 1.0
        a_rgb, _, a_p = train.augment(rgb, depth, probs, rng)
        flipped = a_rgb[:, :, -1, 0] > a_rgb[:, :, 0, 0]
        self.assertTrue(0 < flipped[:, 0].sum() < n)  # both cases occur
        for k in range(n):
            left_class = 1 if not flipped[k, 0] else 2
            self.assertEqual(int(a_p[k, 0, 0].argmax()), left_class)


class SplitAndAgreement(unittest.TestCase):
    def test_held_out_frames_are_never_training_frames(self):
        train, held = distill.split_indices(1000, 700)
        self.assertEqual(len(np.intersect1d(train, held)), 0)
        self.assertEqual(len(train) + len(held), 1000)
        self.assertTrue((held >= 700).all() and (train < 700).all())
        for bad in (0, 1000, 1200, -3):
            with self.assertRaises(ValueError):
                distill.split_indices(1000, bad)

    def test_agreement_counts_argmax_matches_per_teacher_class(self):
        rng = np.random.default_rng(5)
        t = rng.random((3, 10, 12, 14)).astype(np.float32)
        a, per_class = distill.agreement(t.copy(), t)
        self.assertEqual(a, 1.0)
        self.assertEqual(sum(n for n, _ in per_class.values()), 3 * 10 * 12)
        s = t.copy()
        s[0, :, :, :] = 0.0
        s[0, :, :, 13] = 1.0  # frame 0: the student says class 13 everywhere
        a, per_class = distill.agreement(s, t)
        expected = 1.0 - (t[0].argmax(-1) != 13).sum() / t.size * 14
        self.assertAlmostEqual(a, expected, places=6)
        self.assertEqual(sum(k for _, k in per_class.values()), round(a * 3 * 10 * 12))


if __name__ == "__main__":
    unittest.main()
