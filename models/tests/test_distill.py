"""Distillation (edgefusion_models/distill.py): the loss against soft targets, the resampling and
flipping of the teacher's probabilities, the held-out split and the agreement figure."""
import unittest

import numpy as np
import torch
import torch.nn.functional as F

from edgefusion_models import distill, export, net, train


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


class PackAndAugmentation(unittest.TestCase):
    def test_a_pack_keeps_colour_exactly_depth_to_a_centimetre_and_the_teachers_distributions(self):
        import os
        import tempfile
        rng = np.random.default_rng(6)
        n, h, w = 5, 12, 16
        rgb = rng.integers(0, 256, (n, h, w, 3), dtype=np.uint8)
        depth = rng.uniform(0, 8, (n, h, w)).astype(np.float32)
        depth[0, 0, 0] = 0.0  # no depth stays no depth
        teacher = rng.random((n, 3, 4, 14)).astype(np.float32)
        teacher /= teacher.sum(-1, keepdims=True)
        synth = (rng.integers(0, 256, (30, h, w, 3), dtype=np.uint8), rng.uniform(0, 6, (30, h, w)).astype(np.float32),
                 rng.integers(0, 14, (30, h, w), dtype=np.uint8))
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "pack.npz")
            distill.write_pack(path, rgb, depth, teacher, synth)
            r_rgb, r_depth, r_teacher, (s_rgb, s_depth, s_lab) = distill.read_pack(path)
        np.testing.assert_array_equal(r_rgb, rgb)
        self.assertLessEqual(np.abs(r_depth - depth).max(), 0.005 + 1e-6)
        self.assertEqual(r_depth[0, 0, 0], 0.0)
        np.testing.assert_allclose(r_teacher.sum(-1), 1.0, atol=1e-5)
        self.assertLess(np.abs(r_teacher - teacher).max(), 0.02)
        stride = distill.PACK_SYNTHETIC_STRIDE
        np.testing.assert_array_equal(s_rgb, synth[0][::stride])
        np.testing.assert_array_equal(s_lab, synth[2][::stride])
        self.assertLessEqual(np.abs(s_depth - synth[1][::stride]).max(), 0.005 + 1e-6)

    def test_a_file_that_is_not_a_pack_is_named_in_the_error(self):
        import os
        import tempfile
        with tempfile.TemporaryDirectory() as tmp:
            other = os.path.join(tmp, "other.npz")
            np.savez(other, rgb=np.zeros(3))
            with self.assertRaisesRegex(ValueError, "other.npz: not a data pack .*teacher"):
                distill.read_pack(other)
            damaged = os.path.join(tmp, "damaged.npz")
            blob = np.frombuffer(b"RIFF\x10\x00\x00\x00WEBPnot an image", np.uint8)
            np.savez(damaged, rgb=blob, rgb_offsets=np.array([0, len(blob)]), depth_cm=np.zeros((2, 1, 2, 2), np.uint8),
                     teacher=np.zeros((14, 1, 2, 2), np.uint8), synth_rgb=blob, synth_rgb_offsets=np.array([0, len(blob)]),
                     synth_depth_cm=np.zeros((2, 1, 2, 2), np.uint8), synth_labels=np.zeros((1, 2, 2), np.uint8))
            with self.assertRaisesRegex(ValueError, "damaged.npz: a damaged data pack .*image 0"):
                distill.read_pack(damaged)
            cut = os.path.join(tmp, "cut.npz")
            with open(cut, "wb") as f:
                f.write(b"PK\x03\x04 truncated")
            with self.assertRaisesRegex(ValueError, "cut.npz: not a readable data pack"):
                distill.read_pack(cut)

    def test_zoom_moves_the_frame_and_its_targets_together(self):
        rng = np.random.default_rng(7)
        n, h, w = 16, 24, 32
        labels = torch.from_numpy(rng.integers(0, 14, (n, h, w))).long()
        x = torch.zeros(n, 4, h, w)
        x[:, 3] = labels.float()  # the depth channel carries the class id
        x[:, 0] = torch.linspace(0, 1, w)  # a horizontal ramp
        zx, zt = distill.zoom(x, labels, rng, 2.0, nearest_channels=(3,), nearest_target=True)
        self.assertEqual(zt.shape, labels.shape)
        torch.testing.assert_close(zx[:, 3], zt.float())  # the same warp, no blending of the nearest channel
        # Magnified 1-2x: the ramp rises by 1/zoom of its step per pixel, and stays inside its range.
        step = (zx[:, 0, :, 1:] - zx[:, 0, :, :-1]).mean(-1).mean(-1) * (w - 1)
        self.assertTrue(bool((step <= 1 + 1e-4).all() and (step >= 0.5 - 1e-4).all()))
        self.assertLess(float(step.mean()), 0.9)
        self.assertTrue(bool((zx[:, 0] >= -1e-6).all() and (zx[:, 0] <= 1 + 1e-6).all()))
        same_x, same_t = distill.zoom(x, labels, rng, 1.0, nearest_channels=(3,), nearest_target=True)
        torch.testing.assert_close(same_x, x, atol=1e-5, rtol=0)
        torch.testing.assert_close(same_t, labels)

    def test_zoomed_probabilities_stay_distributions(self):
        rng = np.random.default_rng(8)
        p = torch.softmax(torch.randn(4, 14, 12, 16), 1)
        _, zp = distill.zoom(torch.zeros(4, 4, 12, 16), p, rng, 1.7)
        torch.testing.assert_close(zp.sum(1), torch.ones(4, 12, 16), atol=1e-5, rtol=0)


class StudentWidth(unittest.TestCase):
    def test_a_checkpoints_width_is_read_back_from_its_weights(self):
        import os
        import tempfile
        torch.manual_seed(9)
        for width, last in ((2.0, 64), (1.5, 48)):  # 1.5: 32, 48, 96, 192 channels, not a multiple of the stem's
            model = net.EdgeSegNet(width=width).eval()
            self.assertEqual(model.classifier.in_channels, last)
            with tempfile.TemporaryDirectory() as tmp:
                path = os.path.join(tmp, "wide.pt")
                torch.save({"model": model.state_dict()}, path)
                back = export.load_checkpoint(path)
            self.assertEqual(net.count_macs(back), net.count_macs(model))
            x = torch.randn(1, 4, net.INPUT_HEIGHT, net.INPUT_WIDTH)
            with torch.no_grad():
                torch.testing.assert_close(back(x), model(x))

    def test_width_one_is_the_shipped_network(self):
        self.assertEqual([net.channels(c, 1.0) for c in (24, 32, 64, 128)], [24, 32, 64, 128])
        self.assertEqual(net.count_macs(net.EdgeSegNet()), 59232000)
        self.assertGreater(net.count_macs(net.EdgeSegNet(width=2.0)), 3 * 59232000)


if __name__ == "__main__":
    unittest.main()
