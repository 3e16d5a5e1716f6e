"""The C++ inference (nhnet-cli estimate --method nhnet --model --candidate-mix off) runs a model of the "fit"
architecture (training/nhnet_training/model.py NhNetFit) without any core change: same
descriptor in, unit canonical normal out; its normals equal the Python model's on the core's
descriptors (nhnet.descriptors). Needs the build: nhnet-cli with libtorch (scripts/build.sh)
and the bindings, under NHNET_BUILD_DIR (default build/)."""
import os
import subprocess
from pathlib import Path

import numpy as np
import torch

import nhnet
from nhnet_training.config import TrainConfig
from nhnet_training.evaluate import angles, refine
from nhnet_training.export import export
from nhnet_training.model import build_model

REPO = Path(__file__).resolve().parents[2]
CLI = Path(os.environ.get("NHNET_BUILD_DIR", REPO / "build")) / "cli" / "nhnet-cli"


def test_cli_runs_the_fit_architecture(tmp_path):
    assert CLI.exists(), f"{CLI} not built (scripts/build.sh)"
    torch.manual_seed(3)
    cfg = TrainConfig(arch="fit", conv1=4, conv2=4, hidden1=8, hidden2=8, fit_channels=4)
    net = build_model(cfg)
    with torch.no_grad():  # move the candidate choice off its start so the fits count
        net.choose[-1].weight.normal_(0, 0.5)
        net.choose[-1].bias.zero_()
    export(net.eval(), cfg, str(tmp_path / "fit.pt"))
    pts = np.loadtxt(REPO / "data" / "sample" / "fandisk_noise0.6.xyz")[:3000]
    np.savetxt(tmp_path / "p.xyz", pts)
    r = subprocess.run([str(CLI), "estimate", str(tmp_path / "p.xyz"), str(tmp_path / "o.xyzn"),
                        "--method", "nhnet", "--model", str(tmp_path / "fit.pt"), "--orient", "none",
                        "--candidate-mix", "off", "--threads", "1"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    cli = np.loadtxt(tmp_path / "o.xyzn")[:, 3:6]
    d = nhnet.descriptors(pts, threads=1)
    d["mfps"] = d["normals"]
    py = refine(torch.jit.load(str(tmp_path / "fit.pt")).eval(), d)
    # Same float32 kernels on the same descriptors: equal up to summation order (< 0.01 deg).
    assert float(angles(cli, py).max()) < 0.01
    # And the network did change the MFPS normals (the test would pass on MFPS otherwise).
    assert float(np.median(angles(py, d["normals"]))) > 0.05
