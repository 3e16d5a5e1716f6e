"""Resumable training (issue 23): a run interrupted mid-epoch and resumed from last.ckpt ends
with exactly the weights, history and selection of an uninterrupted run of the same seed.

Synthetic descriptors (no core call): what is tested is the trainer's state handling, not the
data. Exact equality is the right bar: the checkpoint holds every piece of state the next step
reads (weights, Adam moments, weight average, step counter of the step-based cosine schedule,
numpy permutation RNG and the epoch's order and position, torch RNG for dropout), training runs
on one thread (deterministic CPU kernels), so any difference would be a state left out."""
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import torch

from nhnet_training.config import NUM_NORMALS, PATCH_SIZE, TrainConfig, descriptor_size
from nhnet_training.train import train


def synthetic(n=1200, seed=0):
    """Descriptor-shaped samples: unit normals with z >= 0, random height maps; target = the self
    normal tilted by an amount the maps encode (something learnable)."""
    rng = np.random.default_rng(seed)
    normals = rng.normal(size=(n, NUM_NORMALS, 3))
    normals[..., 2] = np.abs(normals[..., 2]) + 0.5
    normals /= np.linalg.norm(normals, axis=2, keepdims=True)
    maps = rng.normal(size=(n, NUM_NORMALS * PATCH_SIZE * PATCH_SIZE))
    target = normals[:, 0] + 0.3 * np.c_[maps[:, :2], np.zeros(n)]
    target /= np.linalg.norm(target, axis=1, keepdims=True)
    feats = np.concatenate([normals.reshape(n, -1), maps], axis=1).astype(np.float32)
    assert feats.shape[1] == descriptor_size()
    return {"features": feats, "target": target.astype(np.float32)}


def tiny(out_dir, **kw):
    base = dict(conv1=4, conv2=4, hidden1=8, hidden2=8, epochs=2, batch=128, threads=1,
                lr_schedule="cosine-steps", ema_decay=0.9, max_minutes=30, out_dir=str(out_dir))
    base.update(kw)
    return TrainConfig(**base)


def weights(path):
    return torch.load(str(path), map_location="cpu")["model"]


@pytest.mark.parametrize("stop_at", [3, 11])  # mid-epoch 0 and mid-epoch 1 (8 steps per epoch)
def test_resume_equals_uninterrupted(tmp_path, stop_at):
    data = synthetic()
    full = train(tiny(tmp_path / "full"), data=data, log=lambda s: None)
    cut = train(tiny(tmp_path / "cut"), data=data, log=lambda s: None, stop_after_steps=stop_at)
    assert cut == {"stopped": "interrupted", "epoch": stop_at // 8, "step": stop_at}
    assert not (tmp_path / "cut" / "model.pt").exists()
    ck = torch.load(str(tmp_path / "cut" / "last.ckpt"), map_location="cpu")
    assert ck["run"]["step"] == stop_at and ck["run"]["epoch"] == stop_at // 8
    assert ck["run"]["pos"] == (stop_at % 8) * 128  # position inside the epoch's order
    resumed = train(tiny(tmp_path / "cut"), data=data, log=lambda s: None, resume=True)
    assert resumed["steps"] == full["steps"] == 16 and resumed["epochs_run"] == full["epochs_run"] == 2
    a, b = weights(tmp_path / "full" / "last.ckpt"), weights(tmp_path / "cut" / "last.ckpt")
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    ha = json.loads((tmp_path / "full" / "history.json").read_text())["history"]
    hb = json.loads((tmp_path / "cut" / "history.json").read_text())["history"]
    for ra, rb in zip(ha, hb):
        for key in ("epoch", "train_loss", "val_rms", "val_deg", "val_rms_average"):
            assert ra[key] == rb[key], key
    assert resumed["best_epoch"] == full["best_epoch"] and resumed["val_rms"] == full["val_rms"]
    a, b = weights(tmp_path / "full" / "best.ckpt"), weights(tmp_path / "cut" / "best.ckpt")
    assert all(torch.equal(a[k], b[k]) for k in a)


def test_resume_of_a_finished_run_only_exports(tmp_path):
    data = synthetic()
    first = train(tiny(tmp_path / "r", epochs=1), data=data, log=lambda s: None)
    again = train(tiny(tmp_path / "r", epochs=1), data=data, log=lambda s: None, resume=True)
    assert again["steps"] == first["steps"] == 8 and again["val_rms"] == first["val_rms"]


def test_resume_with_a_raised_limit_goes_on(tmp_path):
    # A run stopped by --epochs 1 trains a second epoch when resumed with --epochs 2 (not the
    # weights of an uninterrupted 2-epoch run: the step-based cosine was sized for one epoch).
    data = synthetic()
    first = train(tiny(tmp_path / "r", epochs=1), data=data, log=lambda s: None)
    assert first["stopped"] == "epochs" and first["steps"] == 8
    before = weights(tmp_path / "r" / "last.ckpt")
    more = train(tiny(tmp_path / "r"), data=data, log=lambda s: None, resume=True)
    assert more["stopped"] == "epochs" and more["steps"] == 16 and more["epochs_run"] == 2
    after = weights(tmp_path / "r" / "last.ckpt")
    assert any(not torch.equal(before[k], after[k]) for k in before)
    history = json.loads((tmp_path / "r" / "history.json").read_text())["history"]
    assert [h["epoch"] for h in history] == [0, 1]


def test_checkpoint_is_replaced_atomically(tmp_path):
    """No temp file is left and last.ckpt always loads (written as temp + rename)."""
    data = synthetic()
    train(tiny(tmp_path / "r"), data=data, log=lambda s: None, stop_after_steps=5)
    files = sorted(p.name for p in (tmp_path / "r").iterdir())
    assert files == ["last.ckpt"]
    torch.load(str(tmp_path / "r" / "last.ckpt"))


def test_selection_by_validation_rms(tmp_path):
    """best.ckpt / model.pt are the epoch (and weights copy) with the lowest validation RMS."""
    info = train(tiny(tmp_path / "r", epochs=3), data=synthetic(), log=lambda s: None)
    hist = json.loads((tmp_path / "r" / "history.json").read_text())["history"]
    cands = [(h["val_rms"], h["epoch"], "raw") for h in hist]
    cands += [(h["val_rms_average"], h["epoch"], "average") for h in hist]
    rms, epoch, kind = min(cands)
    assert (info["val_rms"], info["best_epoch"], info["weights"]) == (rms, epoch, kind)
    for key in ("rms", "mean", "pgp5", "pgp10", "over30"):
        assert np.isfinite(info["val"][key])
    assert 0 <= info["val"]["over30"] <= 100 and info["val"]["pgp5"] <= info["val"]["pgp10"]


def test_sigterm_saves_and_resume_goes_on(tmp_path):
    """The CLI: SIGTERM mid-run -> last.ckpt saved, exit code 3; `--resume` finishes the run."""
    data = synthetic(n=20000)
    np.savez(tmp_path / "data.npz", **data)
    out = tmp_path / "r"
    script = (
        "import sys, numpy as np; import nhnet_training.train as t\n"
        f"d = dict(np.load({str(tmp_path / 'data.npz')!r}))\n"
        "real = t.train\n"
        "t.train = lambda cfg, **kw: real(cfg, data=d, **kw)\n"
        "sys.exit(t.main(sys.argv[1:]))\n")
    args = ["--conv1", "4", "--conv2", "4", "--hidden1", "8", "--hidden2", "8", "--epochs", "200",
            "--batch", "64", "--threads", "1", "--lr-schedule", "cosine-steps", "--out-dir", str(out)]
    env_path = str(Path(__file__).resolve().parents[2] / "training")
    env = {"PYTHONPATH": env_path, "PATH": "/usr/bin:/bin"}
    p = subprocess.Popen([sys.executable, "-c", script] + args, env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    deadline = time.time() + 120
    while not (out / "last.ckpt").exists() and time.time() < deadline:  # first epoch done
        time.sleep(0.2)
    p.terminate()
    log, _ = p.communicate(timeout=60)
    assert p.returncode == 3, log
    assert "interrupted" in log
    ck = torch.load(str(out / "last.ckpt"), map_location="cpu")
    step = ck["run"]["step"]
    assert step >= 1
    # Resume with a shorter budget (epochs is overridable): it goes on from the saved step.
    p2 = subprocess.run([sys.executable, "-c", script] + args[:-2] + ["--out-dir", str(out),
                        "--resume", "--epochs", str(ck["run"]["epoch"] + 1)],
                        env=env, capture_output=True, text=True, timeout=300)
    assert p2.returncode == 0, p2.stdout + p2.stderr
    assert f"resumed {out / 'last.ckpt'}: epoch {ck['run']['epoch']}, step {step}" in p2.stdout
    hist = json.loads((out / "history.json").read_text())
    assert hist["info"]["epochs_run"] == ck["run"]["epoch"] + 1
    assert hist["info"]["steps"] == (ck["run"]["epoch"] + 1) * 266  # 17000 train / 64 -> 266 steps


def test_resume_without_checkpoint_starts_from_the_beginning(tmp_path):
    """A run stopped before its first checkpoint (while building the data) is restarted by the
    same command with --resume: it trains from scratch, same result as without --resume."""
    data = synthetic()
    logs = []
    a = train(tiny(tmp_path / "a", epochs=1), data=data, log=logs.append, resume=True)
    assert any("no " in s and "starting from the beginning" in s for s in logs)
    b = train(tiny(tmp_path / "b", epochs=1), data=data, log=lambda s: None)
    assert a["val_rms"] == b["val_rms"] and a["steps"] == b["steps"]


def test_validation_reported_per_noise_level_and_kind(tmp_path):
    """With cloud names (as build_dataset gives them), every epoch's validation is split by noise
    level (+ density variant) and by CAD / organic training model, and the splits add up."""
    data = synthetic(n=1200)
    data["names"] = np.array(["tripod_noise0.1", "bear_gradient_noise0", "horizons_noise1.2"])
    data["cloud"] = np.repeat(np.arange(3), 400).astype(np.int32)
    logs = []
    train(tiny(tmp_path / "r", epochs=1), data=data, log=logs.append)
    row = json.loads((tmp_path / "r" / "history.json").read_text())["history"][0]
    assert sorted(row["val_groups"]) == ["noise 0% gradient", "noise 0.1%", "noise 1.2%"]
    assert sorted(row["val_kinds"]) == ["CAD", "organic"]
    assert row["val_kinds"]["CAD"]["count"] == row["val_groups"]["noise 0.1%"]["count"]
    assert sum(g["count"] for g in row["val_kinds"].values()) == row["val"]["count"]
    assert any(s.startswith("[train]   organic: RMS") for s in logs)
