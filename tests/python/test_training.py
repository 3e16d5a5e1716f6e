"""Smoke test of the training package: descriptors from the core (bindings) of a small analytic
cloud, a tiny NH-Net trained for a few steps, exported to TorchScript with metadata, reloaded."""
import json

import numpy as np
import pytest

import torch  # noqa: E402  (python3-torch, scripts/install-deps.sh)
import nhnet  # noqa: E402  (the bindings, build/python)

from nhnet_training.config import DESCRIPTOR_VERSION, TrainConfig, descriptor_size  # noqa: E402
from nhnet_training.export import main as export_main, read_metadata  # noqa: E402
from nhnet_training.model import NhNet  # noqa: E402
from nhnet_training.train import WeightAverage, train  # noqa: E402


def half_cube(n, noise, seed):
    """Points on three faces of a cube (sharp edges) with their face normals."""
    rng = np.random.default_rng(seed)
    axis = rng.integers(0, 3, n)
    p = rng.uniform(-1, 1, (n, 3))
    p[np.arange(n), axis] = 1.0
    nrm = np.zeros((n, 3))
    nrm[np.arange(n), axis] = 1.0
    return p + rng.normal(0, noise, (n, 3)), nrm


def samples(seed):
    p, gt = half_cube(3000, 0.01, seed)
    d = nhnet.descriptors(p, threads=2)
    ok = d["valid"]
    t = np.einsum("nij,nj->ni", d["rotations"][ok], gt[ok])
    t *= np.where(np.sum(t * d["features"][ok, :3], axis=1) < 0, -1.0, 1.0)[:, None]
    return {"features": d["features"][ok], "target": t.astype(np.float32)}


def test_descriptor_binding_matches_config():
    assert nhnet.DESCRIPTOR_VERSION == DESCRIPTOR_VERSION
    assert nhnet.DESCRIPTOR_SIZE == descriptor_size()
    s = samples(1)
    assert s["features"].shape[1] == descriptor_size()
    # Canonical frame: every rotated normal has z >= 0 and unit length.
    normals = s["features"][:, :27].reshape(-1, 9, 3)
    assert (normals[..., 2] >= 0).all()
    assert np.allclose(np.linalg.norm(normals, axis=2), 1, atol=1e-5)


def test_train_tiny_and_export(tmp_path):
    cfg = TrainConfig(conv1=4, conv2=4, hidden1=8, hidden2=8, epochs=2, batch=256,
                      out_dir=str(tmp_path / "run"), max_minutes=2)
    info = train(cfg, data=samples(2), log=lambda s: None)
    assert info["val_samples"] > 0 and np.isfinite(info["val_deg"])
    path = tmp_path / "run" / "model.pt"
    meta = read_metadata(str(path))
    assert meta["descriptor_version"] == DESCRIPTOR_VERSION
    assert meta["patch_size"] == 7 and meta["sigma_r"] == [0.1, 0.2, 0.35, 0.5]
    assert json.loads(json.dumps(meta["config"]))["conv1"] == 4
    m = torch.jit.load(str(path))
    x = torch.from_numpy(samples(3)["features"][:64])
    out = m(x)
    assert out.shape == (64, 3)
    assert torch.allclose(out.norm(dim=1), torch.ones(64), atol=1e-5)
    # The checkpoint holds the config too.
    ck = torch.load(str(tmp_path / "run" / "best.ckpt"))
    assert TrainConfig.from_dict(json.loads(ck["config"])).conv1 == 4


def test_weight_average_follows_the_decay():
    torch.manual_seed(0)
    model = NhNet(TrainConfig(conv1=4, conv2=4, hidden1=8, hidden2=8))
    start = {k: v.clone() for k, v in model.state_dict().items()}
    avg = WeightAverage(model, decay=0.5)
    with torch.no_grad():  # new weights (and BatchNorm statistics) all zero
        for v in model.state_dict().values():
            if v.dtype.is_floating_point:
                v.zero_()
        model.state_dict()[next(k for k in start if k.endswith("num_batches_tracked"))].fill_(7)
    avg.update(model)  # step 1: decay min(0.5, 2/11) = 2/11
    d = 2 / 11
    for k, v in avg.model.state_dict().items():
        if v.dtype.is_floating_point:
            assert torch.allclose(v, d * start[k]), k
        else:
            assert torch.equal(v, model.state_dict()[k]), k  # counters copied, not averaged


def test_train_with_weight_average_keeps_the_better_copy(tmp_path):
    cfg = TrainConfig(conv1=4, conv2=4, hidden1=8, hidden2=8, epochs=2, batch=256,
                      out_dir=str(tmp_path / "run"), max_minutes=2, ema_decay=0.9)
    info = train(cfg, data=samples(2), log=lambda s: None)
    hist = json.loads((tmp_path / "run" / "history.json").read_text())["history"]
    assert all(np.isfinite(h["val_rms_average"]) for h in hist)
    best = hist[info["best_epoch"]]
    # Selection by validation RMS (the default select_by).
    kept = min(best["val_rms"], best["val_rms_average"])
    assert info["val_rms"] == pytest.approx(kept)
    assert info["weights"] == ("average" if best["val_rms_average"] < best["val_rms"] else "raw")
    # The exported model is the kept copy: its outputs equal the checkpoint's weights'.
    ck = torch.load(str(tmp_path / "run" / "best.ckpt"))
    assert ck["info"]["weights"] == info["weights"]
    net = NhNet(cfg)
    net.load_state_dict(ck["model"])
    net.eval()
    x = torch.from_numpy(samples(3)["features"][:64])
    with torch.no_grad():
        assert torch.allclose(torch.jit.load(str(tmp_path / "run" / "model.pt"))(x), net(x), atol=1e-5)


def test_loss_terms_weigh_the_tail():
    """sin^2 and the RMS term: zero at the target, sign-free (unoriented), and they add more to
    the loss of one 60-degree error than Eq. 8 alone does relative to small errors."""
    from nhnet_training.model import loss_fn

    t = torch.tensor([[0.0, 0.0, 1.0]])

    def tilt(deg):
        r = np.radians(deg)
        return torch.tensor([[np.sin(r), 0.0, np.cos(r)]], dtype=torch.float32)

    assert float(loss_fn(t, t, 1.0, 1.0)) == pytest.approx(0.0, abs=1e-5)
    # Unoriented: a flipped output costs nothing in the added terms.
    flipped = loss_fn(-t, t, 1.0, 1.0) - loss_fn(-t, t)
    assert float(flipped) == pytest.approx(0.0, abs=1e-5)
    # Eq. 8 alone: 4 sin^2(a/2); sin^2 term: sin^2(a); RMS term: a (radians) for one sample.
    for deg in (5.0, 30.0, 60.0):
        a = np.radians(deg)
        assert float(loss_fn(tilt(deg), t)) == pytest.approx(4 * np.sin(a / 2) ** 2, rel=1e-4)
        assert float(loss_fn(tilt(deg), t, 1.0, 0.0)) == pytest.approx(
            4 * np.sin(a / 2) ** 2 + np.sin(a) ** 2, rel=1e-4)
        assert float(loss_fn(tilt(deg), t, 0.0, 1.0)) == pytest.approx(4 * np.sin(a / 2) ** 2 + a, rel=1e-4)
    # Pull on each sample through the network's normalisation (gradient on the raw output,
    # tangential), 60 vs 5 deg: RMS term = ratio of the angles, 12; Eq. 8 = sin(60)/sin(5) = 9.9;
    # sin^2 = sin(120)/sin(10) = 5.0 (its pull peaks at 45 deg). The RMS term leans on the tail.
    def pull_ratio(w_sin2, w_rms, eq8=False):
        raw = torch.cat([tilt(5.0), tilt(60.0)]).requires_grad_(True)
        out, tt = torch.nn.functional.normalize(raw, dim=1), torch.cat([t, t])
        (loss_fn(out, tt, w_sin2, w_rms) - (0 if eq8 else loss_fn(out, tt))).backward()
        g = raw.grad.norm(dim=1)
        return float(g[1] / g[0])

    def ratio(a, b):
        return np.sin(np.radians(a)) / np.sin(np.radians(b))

    assert pull_ratio(0.0, 1.0) == pytest.approx(12.0, rel=1e-3)
    assert pull_ratio(0.0, 0.0, eq8=True) == pytest.approx(ratio(60, 5), rel=1e-3)
    assert pull_ratio(1.0, 0.0) == pytest.approx(ratio(120, 10), rel=1e-3)


def test_angle_stats():
    from nhnet_training.metrics import angle_stats, grouped_stats

    s = angle_stats([3.0, 4.0, 8.0, 40.0])
    assert s["rms"] == pytest.approx(np.sqrt((9 + 16 + 64 + 1600) / 4))
    assert s["mean"] == pytest.approx(13.75)
    assert (s["pgp5"], s["pgp10"], s["over30"], s["count"]) == (50.0, 75.0, 25.0, 4)
    g = grouped_stats(np.array([1.0, 50.0, 2.0]), np.array(["a", "b", "a"]))
    assert g["a"]["rms"] == pytest.approx(np.sqrt(2.5)) and g["b"]["over30"] == 100.0


def test_export_zeroes_tiny_weights(tmp_path):
    """Weights near the float32 minimum (what weight decay leaves) are stored as 0: their
    products are denormal floats, slow on CPUs; the outputs stay the same."""
    from nhnet_training.export import TINY_WEIGHT, export
    from nhnet_training.model import NhNet

    cfg = TrainConfig(conv1=4, conv2=4, hidden1=8, hidden2=8)
    torch.manual_seed(0)
    model = NhNet(cfg).eval()
    with torch.no_grad():
        w = model.branches[2].weight
        w.view(-1)[:10] = 3e-37
        w.view(-1)[10:20] = -1e-25
        w.view(-1)[20] = 1e-3  # a small but real weight stays
    x = torch.from_numpy(samples(4)["features"][:32])
    with torch.no_grad():
        before = model(x).clone()
    path = tmp_path / "m.pt"
    export(model, cfg, str(path))
    m = torch.jit.load(str(path))
    params = [t for t in list(m.parameters()) + list(m.buffers()) if t.is_floating_point()]
    assert all(int(((t.abs() < TINY_WEIGHT) & (t != 0)).sum()) == 0 for t in params)
    assert float(dict(m.named_parameters())["branches.2.weight"].view(-1)[20]) == pytest.approx(1e-3)
    assert torch.allclose(m(x), before, atol=1e-6)


def test_select_clouds_levels_per_model(tmp_path):
    from nhnet_training.dataset import select_clouds

    levels = [0.0, 0.05, 0.1, 0.2, 0.3, 0.6, 1.2]
    models = [f"m{i}" for i in range(5)]
    clouds = [{"name": f"{m}_noise{lev}", "model": m, "noise_percent": lev, "variant": "uniform"}
              for m in models for lev in levels]
    (tmp_path / "train").mkdir()
    (tmp_path / "train" / "index.json").write_text(json.dumps({"clouds": clouds}))
    base = dict(data_dir=str(tmp_path), noise_levels=levels, variants=["uniform"])

    def pairs(cfg):
        return [(c["model"], c["noise_percent"]) for c in select_clouds(cfg)]

    two = pairs(TrainConfig(**base))
    # Default: two distinct levels per model, one cloud of every model before the second ones.
    assert len(two) == 2 * len(models) and len(set(two)) == len(two)
    assert [m for m, _ in two[:len(models)]] == models
    assert {lev for _, lev in two} == set(levels)
    every = pairs(TrainConfig(levels_per_model=0, **base))
    assert sorted(every) == sorted((m, lev) for m in models for lev in levels)
    assert sorted(pairs(TrainConfig(levels_per_model=len(levels), **base))) == sorted(every)
    three = pairs(TrainConfig(levels_per_model=3, **base))
    assert len(three) == 3 * len(models) and len(set(three)) == len(three)
    assert pairs(TrainConfig(levels_per_model=3, max_clouds=7, **base)) == three[:7]


def test_evaluate_report_per_category_and_noise():
    from nhnet_training.evaluate import report
    from nhnet_training.metrics import angle_stats

    rows = [{"category": "A", "noise": 0.1, "variant": "uniform",
             "mfps": angle_stats([2.0, 40.0]), "m": angle_stats([1.0, 3.0])},
            {"category": "B", "noise": 0.1, "variant": "gradient",
             "mfps": angle_stats([4.0]), "m": angle_stats([5.0])}]
    text = report(rows, ["mfps", "m"])
    lines = text.splitlines()
    # Per category: A's mfps RMS sqrt((4 + 1600) / 2) = 28.32, share over 30 = 50 %.
    assert "| A | 1 | 28.32 | 21.00 | 50.0 | 50.0 | 50.00 | 2.24 | 2.00 | 100.0 | 100.0 | 0.00 |" in lines
    # all = mean of the clouds' figures: m RMS (2.236 + 5) / 2.
    assert any(line.startswith("| all | 2 |") and "| 3.62 |" in line for line in lines)
    assert "| 0.1% gradient | 1 |" in text and "| 0.1% | 1 |" in text


def test_fit_head_recovers_a_tilted_plane():
    """NhNetFit's weighted plane fit: on maps that are an exact plane z = 0.2 u + 0.1 v + 0.05
    (cells) around n = (0, 0, 1), every fit (any positive weights) is the plane's normal
    (-0.2, -0.1, 1) normalised. Tolerance 0.2 deg: the 1e-3 ridge on the normal equations and
    the bins at height exactly 0 (read as empty) move it by less than 0.05 deg."""
    from nhnet_training.model import NhNetFit

    torch.manual_seed(0)
    m = NhNetFit(TrainConfig(arch="fit", fit_channels=4)).eval()
    b = 3
    normals = torch.tensor([0.0, 0.0, 1.0]).repeat(b, 9, 1)
    g = torch.arange(7.0) - 3
    u, v = torch.meshgrid(g, g, indexing="ij")
    maps = (0.2 * u + 0.1 * v + 0.05).repeat(b, 9, 1, 1)
    with torch.no_grad():
        fits = m.fits(normals, maps)
    assert fits.shape == (b, 9 * 2, 3)
    want = torch.nn.functional.normalize(torch.tensor([[-0.2, -0.1, 1.0]]), dim=1)
    err = unoriented(fits.reshape(-1, 3), want.expand(b * 18, 3))
    assert float(err.max()) < 0.2


def unoriented(a, b):
    from nhnet_training.model import unoriented_angle_deg

    return unoriented_angle_deg(a, b)


def test_fit_model_trains_exports_and_starts_at_mfps(tmp_path):
    """arch "fit": TorchScript export with model_format 2 / architecture "fit" metadata (the
    descriptor keys the C++ loader checks unchanged); untrained, its output is the self (MFPS)
    normal up to the softmax's start weight (0.9975 on it): within 1 deg."""
    from nhnet_training.model import build_model

    cfg = TrainConfig(arch="fit", conv1=4, conv2=4, hidden1=8, hidden2=8, fit_channels=4, epochs=1,
                      batch=256, out_dir=str(tmp_path / "run"), max_minutes=2)
    x = torch.from_numpy(samples(3)["features"][:256])
    torch.manual_seed(0)
    fresh = build_model(cfg).eval()
    with torch.no_grad():
        start = fresh(x)
    assert float(unoriented(start, x[:, :3]).max()) < 1.0
    info = train(cfg, data=samples(2), log=lambda s: None)
    assert np.isfinite(info["val_rms"])
    meta = read_metadata(str(tmp_path / "run" / "model.pt"))
    assert (meta["model_format"], meta["architecture"]) == (2, "fit")
    assert meta["descriptor_version"] == DESCRIPTOR_VERSION and meta["patch_size"] == 7
    m = torch.jit.load(str(tmp_path / "run" / "model.pt"))
    ck = torch.load(str(tmp_path / "run" / "best.ckpt"))
    net = build_model(cfg)
    net.load_state_dict(ck["model"])
    net.eval()
    with torch.no_grad():
        assert torch.allclose(m(x), net(x), atol=1e-5)
        assert torch.allclose(m(x).norm(dim=1), torch.ones(len(x)), atol=1e-5)


def test_mlp_model_trains_exports_and_runs_in_the_core(tmp_path):
    """arch "mlp" (an MLP per height map, batched matrix products): untrained it returns the
    self (MFPS) normal exactly (residual, gather's last layer at 0); trained and exported, the
    TorchScript equals the module, and the core runs it through --model like any NH-Net."""
    from nhnet_training.model import build_model

    cfg = TrainConfig(arch="mlp", conv1=16, conv2=8, hidden1=8, hidden2=8, epochs=2, batch=256,
                      out_dir=str(tmp_path / "run"), max_minutes=2)
    x = torch.from_numpy(samples(3)["features"][:256])
    with torch.no_grad():
        start = build_model(cfg).eval()(x)
    # 0.05 deg: float32's acos of a dot product one ulp below 1 is already 0.02 deg
    assert float(unoriented(start, x[:, :3]).max()) < 0.05
    info = train(cfg, data=samples(2), log=lambda s: None)
    assert np.isfinite(info["val_rms"])
    path = tmp_path / "run" / "model.pt"
    assert read_metadata(str(path))["architecture"] == "mlp"
    net = build_model(cfg)
    net.load_state_dict(torch.load(str(tmp_path / "run" / "best.ckpt"))["model"])
    with torch.no_grad():
        trained = net.eval()(x)
        assert torch.allclose(torch.jit.load(str(path))(x), trained, atol=1e-5)
    assert float(unoriented(trained, x[:, :3]).max()) > 0.5  # training moved it off MFPS
    p, _ = half_cube(2000, 0.01, 4)
    r = nhnet.estimate(p, method="nhnet", model=str(path), threads=2)
    normals = np.asarray(r.normals)
    assert r.failed == 0 and np.allclose(np.linalg.norm(normals, axis=1), 1, atol=1e-6)
    # Its metadata names the layers --precision bfloat16 casts; in bfloat16 the core's normals
    # stay near float32's (the matrices and the gathering stay float32; the whole network cast
    # moved the shipped model's 0.63 degree on a noisy sphere, this split 0.005).
    assert read_metadata(str(path))["bfloat16_modules"] == ["layer1", "layer2"]
    f32 = nhnet.estimate(p, method="nhnet", model=str(path), threads=2, precision="float32")
    b16 = nhnet.estimate(p, method="nhnet", model=str(path), threads=2, precision="bfloat16")
    deg = np.degrees(np.arccos(np.abs(np.sum(f32.normals * b16.normals, axis=1)).clip(max=1)))
    assert 0 < deg.mean() < 0.1
    # nhnet-export --reexport: the same weights and metadata through this version's code.
    again = tmp_path / "again.pt"
    assert export_main(["--reexport", str(path), str(again)]) == 0
    assert read_metadata(str(again)) == read_metadata(str(path))
    with torch.no_grad():
        assert torch.equal(torch.jit.load(str(again))(x), torch.jit.load(str(path))(x))


def test_v6_model_still_loads():
    """v6 (shipped until v7; format 1: no model_format key, the paper's architecture, descriptor
    version 1: all k neighbours) loads and runs next to the new format and descriptor."""
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "models" / "nhnet-v6.pt"
    meta = read_metadata(str(path))
    assert "model_format" not in meta and meta["descriptor_version"] == 1 < DESCRIPTOR_VERSION
    m = torch.jit.load(str(path)).eval()
    x = torch.from_numpy(samples(3)["features"][:64])
    with torch.no_grad():
        out = m(x)
    assert torch.allclose(out.norm(dim=1), torch.ones(64), atol=1e-5)


def test_fit_model_warm_starts_from_v6():
    """--init-from models/nhnet-v6.pt: the "fit" network takes v6's branches and gather under the
    same names, so before training it gives v6's output up to the candidate softmax's start
    weight on the self normal (0.9975; the fits share the rest): within 1 deg of v6 here."""
    from pathlib import Path

    from nhnet_training.model import build_model
    from nhnet_training.train import warm_start

    path = str(Path(__file__).resolve().parents[2] / "models" / "nhnet-v6.pt")
    v6 = torch.jit.load(path).eval()
    cfg = TrainConfig.from_dict(read_metadata(path)["config"])
    cfg.arch = "fit"
    net = build_model(cfg)
    n = warm_start(net, path)
    assert n == len(v6.state_dict())  # every v6 tensor found its place
    net.eval()
    x = torch.from_numpy(samples(3)["features"][:256])
    with torch.no_grad():
        assert float(unoriented(net(x), v6(x)).max()) < 1.0
    with pytest.raises(ValueError, match="no parameter matches"):
        warm_start(torch.nn.Linear(2, 2), path)


def test_train_from_v6_logs_the_start(tmp_path):
    """--init-from: the warm start's own validation is logged and kept (what training must beat)."""
    from pathlib import Path

    path = str(Path(__file__).resolve().parents[2] / "models" / "nhnet-v6.pt")
    cfg = TrainConfig(arch="fit", init_from=path, epochs=1, batch=256, out_dir=str(tmp_path / "r"),
                      max_minutes=2)
    logs = []
    info = train(cfg, data=samples(2), log=logs.append)
    assert any(s.startswith("[train] warm start: 29 tensors") for s in logs)
    assert any(s.startswith("[train] before training: val RMS") for s in logs)
    assert 0 < info["val_before_training"]["rms"] < 90


def test_evaluate_picks_distinct_clouds(tmp_path):
    """--per-category larger than a category: every cloud once (it once repeated clouds)."""
    from nhnet_training.evaluate import pick_clouds

    clouds = [{"name": f"c{i}", "category": "A"} for i in range(3)]
    clouds += [{"name": f"d{i}", "category": "B"} for i in range(10)]
    (tmp_path / "benchmark").mkdir()
    (tmp_path / "benchmark" / "index.json").write_text(json.dumps({"clouds": clouds}))
    many = [c["name"] for c in pick_clouds(str(tmp_path), 100, None, None)]
    assert sorted(many) == sorted(c["name"] for c in clouds)
    two = [c["name"] for c in pick_clouds(str(tmp_path), 2, None, None)]
    assert len(two) == len(set(two)) == 4
