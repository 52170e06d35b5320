"""A randomly initialised EdgeSegNet with non-trivial activations, and random input frames: test
material for the exporter and the C++ golden test (export.py --random-init SEED).

Default PyTorch initialisation with identity batch norm statistics gives activations that shrink
towards 0 layer after layer (and near-uniform probabilities). Instead each BatchNorm2d gets the
running statistics of its own input over the random frames (so its output is about N(beta, gamma^2))
with random gamma and beta, and the classifier is scaled up so that the probabilities are peaked.
Statistics are rounded to 6 significant bits so that last-bit differences of the float reductions on
another CPU do not change the model (the committed fixture must be reproducible).
"""
import numpy as np
import torch
import torch.nn as nn

from . import net

LOGIT_GAIN = 6.0  # classifier weights x this: logits of a few units, peaked probabilities


def random_frames(seed, count, height=net.INPUT_HEIGHT, width=net.INPUT_WIDTH):
    """(rgb uint8 N x H x W x 3, depth float32 N x H x W metres): smooth random images with
    texture, a depth ramp and some invalid (0) depth, from numpy's stable RandomState."""
    rs = np.random.RandomState(seed)
    rgb = np.zeros((count, height, width, 3), np.uint8)
    depth = np.zeros((count, height, width), np.float32)
    yy, xx = np.mgrid[0:height, 0:width].astype(np.float64)
    for i in range(count):
        coarse = rs.uniform(0, 255, size=(height // 10 + 1, width // 10 + 1, 3))
        smooth = np.repeat(np.repeat(coarse, 10, 0), 10, 1)[:height, :width]
        rgb[i] = np.clip(smooth + rs.normal(0, 20, size=smooth.shape), 0, 255).astype(np.uint8)
        d = 0.5 + 5.0 * (yy / height) * rs.uniform(0.5, 1.2) + 0.5 * np.sin(xx / rs.uniform(5, 30))
        d = d + rs.normal(0, 0.02, size=d.shape)
        d[rs.uniform(size=d.shape) < 0.05] = 0.0  # invalid pixels
        depth[i] = np.clip(d, 0, 7.5).astype(np.float32)  # a few beyond 6 m: the input saturates
    return rgb, depth


def raw_input(rgb, depth):
    """N x H x W x 4 float32 (R, G, B, depth metres), the network's raw input."""
    return np.concatenate([rgb.astype(np.float32), depth[..., None].astype(np.float32)], axis=3)


def _round_sig(t, bits=6):
    """Rounds each value to `bits` significant bits (float64, then back to the tensor's dtype)."""
    v = t.double().numpy()
    out = np.zeros_like(v)
    nz = v != 0
    e = np.floor(np.log2(np.abs(v[nz])))
    step = np.exp2(e - bits + 1)
    out[nz] = np.round(v[nz] / step) * step
    return torch.from_numpy(out).to(t.dtype)


class _Reached(Exception):
    pass


def random_edgesegnet(seed, frames_raw):
    """An eval-mode EdgeSegNet with seeded weights and data-dependent random BN statistics."""
    torch.manual_seed(seed)
    model = net.EdgeSegNet().eval()
    gen = torch.Generator().manual_seed(seed + 1)
    x = torch.from_numpy(((frames_raw - np.float32(net.INPUT_MEAN)) * np.float32(net.INPUT_SCALE))
                         .transpose(0, 3, 1, 2).copy())
    with torch.no_grad():
        for m in model.modules():
            if isinstance(m, nn.Conv2d):
                m.weight.copy_(_round_sig(m.weight))
        model.classifier.weight.mul_(LOGIT_GAIN)
        model.classifier.bias.uniform_(-1.0, 1.0, generator=gen)
        for bn in [m for m in model.modules() if isinstance(m, nn.BatchNorm2d)]:
            seen = {}

            def grab(mod, inp):
                seen["x"] = inp[0]
                raise _Reached()  # the rest of the forward pass is not needed
            hook = bn.register_forward_pre_hook(grab)
            try:
                model(x)  # earlier BNs already hold their final statistics
            except _Reached:
                pass
            hook.remove()
            inp = seen["x"].double()
            mean = inp.mean(dim=(0, 2, 3))
            var = inp.var(dim=(0, 2, 3), unbiased=False)
            c = mean.numel()
            # Shifted means and scaled variances: activations differ from a plain whitening.
            jitter = (torch.rand(c, generator=gen, dtype=torch.float64) - 0.5) * 0.4
            bn.running_mean.copy_(_round_sig((mean + jitter * var.sqrt()).float()))
            bn.running_var.copy_(_round_sig((var * (0.6 + 0.8 * torch.rand(c, generator=gen, dtype=torch.float64)))
                                            .clamp_min(1e-6).float()))
            bn.weight.copy_(_round_sig(0.5 + 2.0 * torch.rand(c, generator=gen)))
            bn.bias.copy_(_round_sig(torch.rand(c, generator=gen) * 1.5 - 0.25))
    return model


def describe(seed):
    return f"random EdgeSegNet (seed {seed}, BN statistics from random frames; test material, not trained)"

