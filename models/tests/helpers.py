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


def resize_model(seed=7):
    """The layers a DeepLabv3 head adds, in a 17 x 25 x 4 -> 33 x 33 x 7 network (validated): bilinear
    resizes up (17x25 -> 33x49), as a broadcast (1x1 -> 33x49) and down (33x49 -> 20x20), a global
    average pool of 33 x 49 (above the 31 of ordinary windows), a requantising concat, and a class map
    of the 7 outputs into 4 target classes (a version 2 file). The C++ fixture
    tests/data/nn/resize_pool_cmap/ is this model (test_resize_pool_cmap.py)."""
    from edgefusion_models.qmodel import DType, LayerType as T, QLayer, QModel, QTensor, validate
    rng = np.random.RandomState(seed)

    def t(h, w, c, s, z):
        return QTensor(h=h, w=w, c=c, scale=s, zero_point=z)

    tensors = [t(17, 25, 4, 0.02, -3),     # 0 input
               t(17, 25, 16, 0.05, 4),     # 1 pointwise
               t(33, 49, 16, 0.05, 4),     # 2 resize up
               t(1, 1, 16, 0.02, -9),      # 3 global average pool 33 x 49
               t(33, 49, 16, 0.02, -9),    # 4 resize 1x1 -> 33x49 (broadcast)
               t(33, 49, 32, 0.06, 2),     # 5 concat (2, 4), requantising
               t(20, 20, 32, 0.06, 2),     # 6 resize down
               t(20, 20, 7, 0.11, -7),     # 7 pointwise: logits
               t(33, 33, 7, 0.11, -7),     # 8 resize up (non-integer ratio)
               QTensor(h=33, w=33, c=7, dtype=DType.FLOAT32)]  # 9 probabilities
    pw1 = QLayer(T.POINTWISE_CONV2D, [0], 1)
    fill_conv(pw1, 16, 4, rng)
    gap = QLayer(T.AVG_POOL, [2], 3, kernel_h=33, kernel_w=49)
    pw2 = QLayer(T.POINTWISE_CONV2D, [6], 7)
    fill_conv(pw2, 7, 32, rng)
    L = [pw1, QLayer(T.RESIZE_BILINEAR, [1], 2), gap, QLayer(T.RESIZE_BILINEAR, [3], 4), QLayer(T.CONCAT, [2, 4], 5),
         QLayer(T.RESIZE_BILINEAR, [5], 6), pw2, QLayer(T.RESIZE_BILINEAR, [7], 8), QLayer(T.SOFTMAX, [8], 9)]
    m = QModel(name="resize-pool-cmap", input_tensor=0, output_tensor=9, input_mean=[128.0, 128.0, 128.0, 2.0],
               input_scale=[1 / 64, 1 / 64, 1 / 64, 1.0], class_names=[f"out{k}" for k in range(7)],
               tensors=tensors, layers=L, tensor_names=[f"t{i}" for i in range(10)],
               class_map=[0, 1, 1, 2, 3, 3, 0], target_class_names=["unknown", "wall", "floor", "other"])
    validate(m)
    return m
