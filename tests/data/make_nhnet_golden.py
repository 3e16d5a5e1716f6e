"""Writes the NH-Net consistency fixtures used by tests/core/test_nhnet_model.cpp:
  nhnet_tiny.pt         a tiny NH-Net (random init, seed 1, a few training steps), TorchScript
  nhnet_tiny_v0.pt      the same with descriptor_version 0 (the loader must refuse it)
  nhnet_golden.bin      a fixed cloud, its descriptors from nhnet.descriptors (what training
                        sees) and the Python model's outputs on them
Regenerate (after a descriptor change) from the repository root:
  PYTHONPATH=build/python:training /usr/bin/python3 tests/data/make_nhnet_golden.py [--golden-only]
--golden-only keeps the committed tiny models (nhnet_tiny.pt is exported for descriptor version 1,
which test KnowsItsDescriptorVersion relies on) and rewrites nhnet_golden.bin with their outputs.
Layout of nhnet_golden.bin (little endian): b"NHG2", int64 n, int64 d, int64 m, float64
points[n][3], then for m checked rows (every 15th point): int64 index[m], uint8 valid[m], float32
features[m][d], float32 outputs[m][3] (NaN rows where not valid)."""
import struct
import sys
from pathlib import Path

import numpy as np
import torch

import nhnet
from nhnet_training import config as C
from nhnet_training.config import TrainConfig
from nhnet_training.export import export
from nhnet_training.model import NhNet, loss_fn

HERE = Path(__file__).resolve().parent


def cloud(n=1500, seed=7):
    rng = np.random.default_rng(seed)
    axis = rng.integers(0, 3, n)
    p = rng.uniform(-1, 1, (n, 3))
    p[np.arange(n), axis] = 1.0
    return p + rng.normal(0, 0.01, (n, 3))


def train_tiny(x):
    """The tiny models, trained a few steps on descriptors x, exported next to this script."""
    cfg = TrainConfig(conv1=4, conv2=4, hidden1=8, hidden2=8)
    model = NhNet(cfg)
    # A few steps towards the MFPS normal so the weights are not the initial ones.
    opt = torch.optim.Adam(model.parameters(), lr=1e-2)
    model.train()
    for _ in range(5):
        loss = loss_fn(model(x), x[:, :3])
        opt.zero_grad()
        loss.backward()
        opt.step()
    model.eval()
    export(model, cfg, str(HERE / "nhnet_tiny.pt"), {"purpose": "test fixture"})
    version = C.DESCRIPTOR_VERSION
    C.DESCRIPTOR_VERSION = 0
    export(model, cfg, str(HERE / "nhnet_tiny_v0.pt"), {"purpose": "test fixture, wrong version"})
    C.DESCRIPTOR_VERSION = version


def main():
    torch.manual_seed(1)
    torch.set_num_threads(2)
    pts = cloud()
    d = nhnet.descriptors(pts, threads=2)
    x = torch.from_numpy(d["features"][d["valid"]])
    if "--golden-only" not in sys.argv[1:]:
        train_tiny(x)
    scripted = torch.jit.load(str(HERE / "nhnet_tiny.pt"))
    n, dim = d["features"].shape
    out = np.full((n, 3), np.nan, np.float32)
    with torch.no_grad():
        out[d["valid"]] = scripted(x).numpy()
    rows = np.arange(0, n, 15)
    with open(HERE / "nhnet_golden.bin", "wb") as f:
        f.write(b"NHG2" + struct.pack("<qqq", n, dim, len(rows)))
        f.write(pts.astype("<f8").tobytes())
        f.write(rows.astype("<i8").tobytes())
        f.write(d["valid"][rows].astype(np.uint8).tobytes())
        f.write(d["features"][rows].astype("<f4").tobytes())
        f.write(out[rows].astype("<f4").tobytes())
    models = "" if "--golden-only" in sys.argv[1:] else " and the tiny models"
    print(f"wrote {n} x {dim} golden data{models} into {HERE}")


if __name__ == "__main__":
    main()
