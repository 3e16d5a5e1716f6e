"""The C++ inference (nhnet-cli estimate --method nhnet --model --candidate-mix off) runs a model of the "fit"
architecture (training/nhnet_training/model.py NhNetFit) without any core change: same
descriptor in, unit canonical normal out; its normals equal the Python model's on the core's
descriptors (nhnet.descriptors). Needs the build: nhnet-cli with libtorch (scripts/build.sh)
and the bindings, under NHNET_BUILD_DIR (default build/)."""
import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
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


def _sample(n):
    gt = np.loadtxt(REPO / "data" / "sample" / "fandisk_noise0.6.gt.xyzn")[:n]
    return np.loadtxt(REPO / "data" / "sample" / "fandisk_noise0.6.xyz")[:n], gt[:, 3:6]


def test_cli_describes_for_the_models_descriptor_version(tmp_path):
    """A version-1 model (the golden tiny one, like the shipped v6) gets version-1 descriptors
    (all k neighbours) from nhnet-cli, not the latest version's capped ones: on this noisy
    cloud (k above the cap) the two differ, and the CLI's normals match Python's refinement of
    the version-1 descriptors only."""
    pts, _ = _sample(3000)
    np.savetxt(tmp_path / "p.xyz", pts)
    model = REPO / "tests" / "data" / "nhnet_tiny.pt"
    r = subprocess.run([str(CLI), "estimate", str(tmp_path / "p.xyz"), str(tmp_path / "o.xyzn"),
                        "--method", "nhnet", "--model", str(model), "--orient", "none",
                        "--candidate-mix", "off", "--threads", "1"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    cli = np.loadtxt(tmp_path / "o.xyzn")[:, 3:6]
    net = torch.jit.load(str(model)).eval()
    out = {}
    for version in (1, 2):
        d = nhnet.descriptors(pts, threads=1, version=version)
        d["mfps"] = d["normals"]
        out[version] = refine(net, d)
    assert d["k_used"] > 64  # the cap acts here
    assert float(angles(cli, out[1]).max()) < 0.01  # summation order only
    assert float(angles(cli, out[2]).max()) > 0.1


def test_evaluate_runs_models_of_two_descriptor_versions(tmp_path, capsys):
    """nhnet-evaluate end to end on a one-cloud benchmark: a version-1 and a version-2 model,
    each on its own descriptors, reported side by side."""
    from nhnet_training.evaluate import main

    pts, gt = _sample(2500)
    bench = tmp_path / "data" / "benchmark"
    bench.mkdir(parents=True)
    np.savetxt(bench / "f.xyz", pts)
    np.savetxt(bench / "f.normals", gt)
    cloud = {"name": "f", "category": "BigNoise", "noise_percent": 0.6, "variant": "uniform",
             "files": ["f.xyz", "f.normals"]}
    (bench / "index.json").write_text(json.dumps({"clouds": [cloud]}))
    torch.manual_seed(5)
    cfg = TrainConfig(conv1=4, conv2=4, hidden1=8, hidden2=8)
    net = build_model(cfg)
    with torch.no_grad():
        net.gather[-1].weight.normal_(0, 0.3)  # off the identity start: a real correction
    export(net.eval(), cfg, str(tmp_path / "v2.pt"))
    v1 = REPO / "tests" / "data" / "nhnet_tiny.pt"
    assert main(["--data-dir", str(tmp_path / "data"), "--model", str(v1), str(tmp_path / "v2.pt"),
                 "--per-category", "1", "--points", "500", "--cache", str(tmp_path / "cache"),
                 "--threads", "1", "--json", str(tmp_path / "r.json"), "--default"]) == 0
    rows = json.loads((tmp_path / "r.json").read_text())
    assert len(rows) == 1 and {"data/nhnet_tiny", f"{tmp_path.name}/v2"} <= set(rows[0])
    # --default: the core's whole pipeline with the v2 model, scored at the same 500 points
    whole = nhnet.estimate_normals(pts, method="nhnet", model=str(tmp_path / "v2.pt"), threads=1,
                                   orient=None)
    with np.load(next((tmp_path / "cache").glob("v2-*")) / "f.npz") as z:
        at = np.sort(np.random.default_rng(12345).choice(len(z["rows"]), 500, replace=False))
        picked = z["rows"][at]
    want = np.sqrt(np.mean(angles(whole[picked], gt[picked]) ** 2))
    assert rows[0][f"{tmp_path.name}/v2 default"]["rms"] == pytest.approx(want, abs=1e-9)
    assert sorted(p.name.split("-")[0] for p in (tmp_path / "cache").iterdir()) == ["v1", "v2"]
    assert "| all | 1 |" in capsys.readouterr().out
