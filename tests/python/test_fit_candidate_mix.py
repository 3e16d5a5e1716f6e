"""tools/fit_candidate_mix.py (issue 23): `data` stores each point's descriptor and frame, and
`fit` / `report --model M` recompute the network column from them, so that a new model of the
same descriptor version needs no new `data` run. The recomputed column must be the one a `data`
run with M itself stores; a model of another descriptor version is refused."""
import json
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from nhnet_training.config import TrainConfig
from nhnet_training.evaluate import model_and_version
from nhnet_training.export import export
from nhnet_training.model import build_model

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tools"))
import fit_candidate_mix as mix  # noqa: E402


def random_model(path, seed):
    torch.manual_seed(seed)
    cfg = TrainConfig(arch="mlp", conv1=8, conv2=8, hidden1=8, hidden2=8)
    net = build_model(cfg)
    with torch.no_grad():
        net.gather[-1].weight.normal_(0, 0.3)  # a real correction, not the identity start
    export(net.eval(), cfg, str(path))
    return model_and_version(str(path))


def one_cloud_benchmark(root):
    """root/benchmark with one cloud (2 500 points of the bundled noisy sample); its index entry."""
    base = root / "benchmark"
    base.mkdir()
    sample = REPO / "data" / "sample"
    np.savetxt(base / "f.xyz", np.loadtxt(sample / "fandisk_noise0.6.xyz")[:2500])
    np.savetxt(base / "f.normals", np.loadtxt(sample / "fandisk_noise0.6.gt.xyzn")[:2500, 3:6])
    cloud = {"name": "f", "category": "BigNoise", "noise_percent": 0.6, "variant": "uniform",
             "model": "fandisk", "files": ["f.xyz", "f.normals"]}
    (base / "index.json").write_text(json.dumps({"clouds": [cloud]}))
    return cloud


def test_stored_descriptors_give_any_models_network_column(tmp_path):
    cloud = one_cloud_benchmark(tmp_path)
    a, b = random_model(tmp_path / "a.pt", 1), random_model(tmp_path / "b.pt", 2)
    za = mix.cloud_data(tmp_path, "benchmark", cloud, a, 1)
    zb = mix.cloud_data(tmp_path, "benchmark", cloud, b, 1)
    assert mix.angle(za["net"], zb["net"]).max() > np.radians(1)  # two models, two columns
    again = mix.with_model(za, b)
    assert np.degrees(mix.angle(again["net"], zb["net"])).max() < 1e-4  # the same floats
    v1 = model_and_version(str(REPO / "tests" / "data" / "nhnet_tiny.pt"))
    with pytest.raises(SystemExit, match="version 2, the model reads version 1"):
        mix.with_model(za, v1)


def test_fit_and_report_take_a_model(tmp_path, capsys):
    one_cloud_benchmark(tmp_path)
    random_model(tmp_path / "a.pt", 1)
    random_model(tmp_path / "b.pt", 2)
    assert mix.main(["data", "--split", "benchmark", "--data-dir", str(tmp_path), "--out",
                     str(tmp_path / "d"), "--model", str(tmp_path / "a.pt"), "--threads", "1"]) == 0
    inc = tmp_path / "w.inc"
    assert mix.main(["fit", str(tmp_path / "d"), "--model", str(tmp_path / "b.pt"), "--epochs", "2",
                     "--threads", "1", "--write", str(inc)]) == 0
    assert inc.stat().st_size > 0
    capsys.readouterr()
    tables = []
    for model in ([], ["--model", str(tmp_path / "b.pt")]):
        assert mix.main(["report", str(tmp_path / "d"), "--weights", str(inc)] + model) == 0
        tables.append(capsys.readouterr().out)
    # the first column after the cloud count is the network's RMS: model a's, then b's
    net_rms = [float(t.split("| all | 1 |")[1].split("|")[0]) for t in tables]
    assert net_rms[0] != net_rms[1]
