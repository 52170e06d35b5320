"""EdgeSegNet: the RGB-D segmentation network shipped with EdgeFusion.

Input: 120 x 160 (rows x columns) RGB + depth, normalised by INPUT_MEAN / INPUT_SCALE
(R, G, B in 0..255; depth in metres, 0 = invalid). Output: logits of the 13 NYUv2 classes plus
unknown (id 0), 14 channels, at the input resolution.

Every layer is one the int8 runtime has (docs/model_format.md): 3x3 convolutions (stride 1/2),
3x3 depthwise convolutions (stride 1/2, dilation), pointwise convolutions, ReLU6, bilinear x2
upsampling with half-pixel centres (align_corners=False), concatenation along channels, softmax.
Batch normalisation is folded into the convolutions at export.

Why 160 x 120: tracking and label fusion run at 320x240; the CNN runs every N-th frame and its
probabilities are upsampled by nearest neighbour (the paper upsamples 224x224 likewise). Half the
working resolution keeps the whole forward pass near 70 MMAC, a few ms on one x86 core and tens of
ms on a Cortex-A72, while objects of the 13 classes keep tens of pixels across.
"""
import torch
import torch.nn as nn
import torch.nn.functional as F

INPUT_HEIGHT = 120
INPUT_WIDTH = 160
NUM_CLASSES = 14  # 0 = unknown, 1..13 = the NYUv2 classes (src/core/classes.h order)
CLASS_NAMES = ["unknown", "bed", "books", "ceiling", "chair", "floor", "furniture", "objects",
               "painting", "sofa", "table", "tv", "wall", "window"]
# Normalised input = (value - mean) * scale: RGB 0..255 -> -1..1; depth 0..6 m -> -1..1 (beyond 6 m
# saturates in the int8 input, and training clamps depth at 6 m to match).
INPUT_MEAN = [127.5, 127.5, 127.5, 3.0]
INPUT_SCALE = [1.0 / 127.5, 1.0 / 127.5, 1.0 / 127.5, 1.0 / 3.0]
DEPTH_MAX_M = 6.0


class ConvBNReLU6(nn.Sequential):
    """Convolution (no bias) + batch norm + ReLU6; groups == channels makes it depthwise."""

    def __init__(self, cin, cout, k=1, stride=1, dilation=1, depthwise=False, relu=True):
        pad = dilation * (k - 1) // 2
        layers = [nn.Conv2d(cin, cout, k, stride, pad, dilation, groups=cin if depthwise else 1, bias=False),
                  nn.BatchNorm2d(cout)]
        if relu:
            layers.append(nn.ReLU6(inplace=False))
        super().__init__(*layers)


class DwPw(nn.Sequential):
    """Depthwise 3x3 (+BN+ReLU6) then pointwise (+BN+ReLU6): the MobileNet block."""

    def __init__(self, cin, cout, stride=1, dilation=1):
        super().__init__(ConvBNReLU6(cin, cin, 3, stride, dilation, depthwise=True),
                         ConvBNReLU6(cin, cout, 1))


def channels(c, width):
    """The shipped network's c channels scaled by `width` (1.0 = the shipped network), in multiples
    of 8 (the int8 kernels' channel blocks), at least 8."""
    return max(8, int(round(c * width / 8.0)) * 8)


class EdgeSegNet(nn.Module):
    """width: channel multiplier (1.0 = the shipped network, 59 MMAC; 2.0 is about 4x the
    multiply-adds). Only the layer widths change: the wiring and the layer names stay, so a
    checkpoint's widths follow from its weights (export.load_checkpoint passes them as `widths`,
    the four channel counts that stand for the shipped network's 24, 32, 64 and 128)."""

    def __init__(self, num_classes=NUM_CLASSES, width=1.0, widths=None):
        super().__init__()
        c24, c32, c64, c128 = widths if widths is not None else (channels(c, width) for c in (24, 32, 64, 128))
        self.width = c24 / 24.0 if widths is not None else width
        self.stem = ConvBNReLU6(4, c24, 3, stride=2)             # 60x80x24
        self.enc1 = DwPw(c24, c32)                                # 60x80x32  (skip 1)
        self.enc2 = nn.Sequential(DwPw(c32, c64, stride=2),       # 30x40x64
                                  DwPw(c64, c64))                 # (skip 2)
        self.enc3 = nn.Sequential(DwPw(c64, c128, stride=2),      # 15x20x128
                                  DwPw(c128, c128, dilation=2),
                                  DwPw(c128, c128, dilation=4))
        self.reduce3 = ConvBNReLU6(c128, c64, 1)                  # 15x20x64
        self.dec2 = nn.Sequential(ConvBNReLU6(2 * c64, c64, 1),   # concat(up(reduce3), skip2) 30x40
                                  ConvBNReLU6(c64, c64, 3, depthwise=True),
                                  ConvBNReLU6(c64, c32, 1))
        self.dec1 = nn.Sequential(ConvBNReLU6(2 * c32, c32, 1),   # concat(up(dec2), skip1) 60x80
                                  ConvBNReLU6(c32, c32, 3, depthwise=True))
        self.classifier = nn.Conv2d(c32, num_classes, 1, bias=True)  # logits 60x80

    @staticmethod
    def up2(x):
        return F.interpolate(x, scale_factor=2, mode="bilinear", align_corners=False)

    def forward(self, x):
        s1 = self.enc1(self.stem(x))
        s2 = self.enc2(s1)
        x = self.reduce3(self.enc3(s2))
        x = self.dec2(torch.cat([self.up2(x), s2], 1))
        x = self.dec1(torch.cat([self.up2(x), s1], 1))
        return self.up2(self.classifier(x))                    # logits 120x160


def count_macs(model, h=INPUT_HEIGHT, w=INPUT_WIDTH):
    """Multiply-accumulates of the convolutions for one forward pass."""
    macs = 0

    def hook(mod, inp, out):
        nonlocal macs
        k = mod.kernel_size[0] * mod.kernel_size[1]
        macs += out.numel() * k * (mod.in_channels // mod.groups)

    hs = [m.register_forward_hook(hook) for m in model.modules() if isinstance(m, nn.Conv2d)]
    with torch.no_grad():
        model.eval()
        model(torch.zeros(1, 4, h, w))
    for hnd in hs:
        hnd.remove()
    return macs
