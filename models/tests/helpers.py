"""Shared test material: a random EdgeSegNet (built once per process), its frames, a tiny
quantised model using every layer type."""
import functools
import os

import numpy as np

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FIXTURE_DIR = os.path.join(REPO_ROOT, "tests", "data", "nn", "random_edgesegnet")


@functools.lru_cache(maxsize=None)
def random_net(seed=3, frames=3):
    """(eval-mode EdgeSegNet, raw frames N x 120 x 160 x 4) of a seed."""
    from edgefusion_models import random_init
    rgb, depth = random_init.random_frames(seed, frames)
    raw = random_init.raw_input(rgb, depth)
    return random_init.random_edgesegnet(seed, raw), raw


@functools.lru_cache(maxsize=None)
def random_net_graph(seed=3):
    from edgefusion_models.from_torch import from_edgesegnet
    return from_edgesegnet(random_net(seed)[0])


def fill_conv(layer, cout, per_channel, rng):
    """Random symmetric weights, scales and biases (as tests/nn/nn_test_util.h fill_weights)."""
    layer.weight_scales = rng.uniform(0.002, 0.02, cout).astype(np.float32)
    layer.bias = rng.randint(-2000, 2001, cout).astype(np.int32)
    layer.weights = rng.randint(-127, 128, cout * per_channel).astype(np.int8)


def tiny_model(seed=1):
    """A 6 x 8 x 4 -> 6 x 8 x 5 network with every layer type, odd paddings, strides, dilations,
    requantising concat, bilinear x2 and x3, and a side branch; validated."""
    from edgefusion_models.qmodel import (Activation, DType, LayerType as T, QLayer, QModel, QTensor,
                                          UpsampleMode, validate)
    rng = np.random.RandomState(seed)

    def t(h, w, c, s, z):
        return QTensor(h=h, w=w, c=c, scale=s, zero_point=z)

    tensors = [t(6, 8, 4, 0.02, -3),      # 0 input
               t(6, 8, 8, 0.03, -20),     # 1 conv 3x3
               t(3, 4, 8, 0.04, 3),       # 2 depthwise stride 2, pads top/left only
               t(3, 4, 8, 0.05, -5),      # 3 pointwise
               t(3, 4, 8, 0.07, -10),     # 4 add
               t(3, 4, 8, 0.07, -10),     # 5 clamp
               t(3, 4, 8, 0.07, -10),     # 6 max pool 2x2, pads top/left
               t(3, 4, 8, 0.03, 7),       # 7 avg pool 3x3 pad 1
               t(6, 8, 8, 0.03, 7),       # 8 bilinear x2
               t(6, 8, 8, 0.07, -10),     # 9 nearest x2
               t(6, 8, 24, 0.06, 2),      # 10 concat (9, 1, 8), requantising
               t(6, 8, 5, 0.1, 2),        # 11 conv 3x3 dilation 2
               QTensor(h=6, w=8, c=5, dtype=DType.FLOAT32),  # 12 probabilities
               t(9, 12, 8, 0.07, -10),    # 13 bilinear x3 (side branch)
               t(3, 4, 6, 0.05, -128)]    # 14 conv 3x3 stride 3, ReLU
    L = []
    conv = QLayer(T.CONV2D, [0], 1, act=Activation.RELU6, kernel_h=3, kernel_w=3, pad_top=1, pad_left=1,
                  pad_bottom=1, pad_right=1, out_min=-20, out_max=90)
    fill_conv(conv, 8, 36, rng)
    dw = QLayer(T.DEPTHWISE_CONV2D, [1], 2, kernel_h=3, kernel_w=3, stride_h=2, stride_w=2, pad_top=1, pad_left=1)
    fill_conv(dw, 8, 9, rng)
    pw = QLayer(T.POINTWISE_CONV2D, [2], 3)
    fill_conv(pw, 8, 8, rng)
    add = QLayer(T.ADD, [2, 3], 4, act=Activation.CLAMP, out_min=-100, out_max=100)
    clamp = QLayer(T.CLAMP, [4], 5, act=Activation.CLAMP, out_min=-50, out_max=60)
    maxp = QLayer(T.MAX_POOL, [5], 6, kernel_h=2, kernel_w=2, pad_top=1, pad_left=1)
    avgp = QLayer(T.AVG_POOL, [6], 7, kernel_h=3, kernel_w=3, pad_top=1, pad_left=1, pad_bottom=1, pad_right=1)
    up_b = QLayer(T.UPSAMPLE, [7], 8, factor=2, mode=UpsampleMode.BILINEAR)
    up_n = QLayer(T.UPSAMPLE, [5], 9, factor=2, mode=UpsampleMode.NEAREST)
    cat = QLayer(T.CONCAT, [9, 1, 8], 10)
    head = QLayer(T.CONV2D, [10], 11, kernel_h=3, kernel_w=3, dilation_h=2, dilation_w=2, pad_top=2, pad_left=2,
                  pad_bottom=2, pad_right=2)
    fill_conv(head, 5, 9 * 24, rng)
    sm = QLayer(T.SOFTMAX, [11], 12)
    up3 = QLayer(T.UPSAMPLE, [6], 13, factor=3, mode=UpsampleMode.BILINEAR)
    side = QLayer(T.CONV2D, [13], 14, act=Activation.RELU, kernel_h=3, kernel_w=3, stride_h=3, stride_w=3)
    fill_conv(side, 6, 72, rng)
    L = [conv, dw, pw, add, clamp, maxp, avgp, up_b, up_n, cat, head, up3, side, sm]
    m = QModel(name="tiny", input_tensor=0, output_tensor=12, input_mean=[128.0, 128.0, 128.0, 2.0],
               input_scale=[1 / 64, 1 / 64, 1 / 64, 1.0], class_names=["wall", "floor", "chair", "table", "other"],
               tensors=tensors, layers=L)
    validate(m)
    return m


def random_input(model, seed=0):
    t = model.tensors[model.input_tensor]
    return np.random.RandomState(seed).randint(-128, 128, size=(t.h, t.w, t.c)).astype(np.int8)
