"""Golden files for the C++ bit-exactness test (tests/nn/test_nn_golden.cpp).

A golden directory holds
  input_q.bin      the int8 input tensor (H x W x C), quantised from a real frame (docs 3.1)
  output_rows.bin  float32 probabilities of a few rows (each W x K, row-major), as the runtime writes them
  manifest.txt     one record per line, "key values...": the shapes, the CRC32 of the full float32
                   output, of the model file and of every int8 tensor (to name the first layer that
                   differs when the runtime disagrees)
The full output is 120 x 160 x 14 float32 = 1 MB; its CRC32 plus exact rows keep the directory small
while still asserting every byte. CRC32 is zlib's, which the runtime exposes as ef::nn::crc32.
"""
import os
import zlib

import numpy as np

MANIFEST = "manifest.txt"
INPUT_FILE = "input_q.bin"
ROWS_FILE = "output_rows.bin"
FORMAT_VERSION = 1


def crc32(data):
    return zlib.crc32(np.ascontiguousarray(data).tobytes() if isinstance(data, np.ndarray) else data) & 0xFFFFFFFF


def golden_rows(height):
    """First, middle and last row of the output."""
    return sorted({0, height // 2, height - 1})


def write(directory, model, model_bytes, input_q, probs, tensors, description):
    """Writes the golden files of one run: model (QModel), model_bytes (the .efm file), input_q
    (int8 H x W x C), probs (float32 H' x W' x K), tensors ({id: int8 array}) from int8_ref.run."""
    os.makedirs(directory, exist_ok=True)
    h, w, k = probs.shape
    rows = golden_rows(h)
    probs = np.ascontiguousarray(probs, dtype="<f4")
    with open(os.path.join(directory, INPUT_FILE), "wb") as f:
        f.write(np.ascontiguousarray(input_q, dtype=np.int8).tobytes())
    with open(os.path.join(directory, ROWS_FILE), "wb") as f:
        f.write(probs[rows].tobytes())
    t_in = model.tensors[model.input_tensor]
    lines = [
        "# EdgeFusion int8 golden (docs/model_format.md); written by edgefusion_models.export. Do not edit.",
        f"format {FORMAT_VERSION}",
        f"description {description}",
        f"model_crc32 0x{crc32(model_bytes):08x} {len(model_bytes)}",
        f"input {INPUT_FILE} {t_in.h} {t_in.w} {t_in.c}",
        f"output {h} {w} {k} crc32 0x{crc32(probs):08x}",
        f"rows {ROWS_FILE} " + " ".join(str(r) for r in rows),
    ]
    for tid in sorted(tensors):
        t = model.tensors[tid]
        name = model.tensor_names[tid] if tid < len(model.tensor_names) else ""
        lines.append(f"tensor {tid} {t.h} {t.w} {t.c} crc32 0x{crc32(tensors[tid]):08x} {name}".rstrip())
    with open(os.path.join(directory, MANIFEST), "w") as f:
        f.write("\n".join(lines) + "\n")


def read_manifest(directory):
    """{key: [value tokens...]} with "tensor" records as {id: [tokens...]} under "tensors"."""
    out = {"tensors": {}}
    with open(os.path.join(directory, MANIFEST)) as f:
        for line in f:
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            key, *vals = line.split()
            if key == "tensor":
                out["tensors"][int(vals[0])] = vals[1:]
            else:
                out[key] = vals
    return out
