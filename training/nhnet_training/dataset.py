"""Training samples from the generator's training split (`nhnet-datagen --set train`).

Descriptors come from the core through the Python bindings (`nhnet.descriptors`, the same call
that inference makes); nothing is recomputed here. Per cloud, a fixed random subset of points is
kept: 2/3 uniform, 1/3 drawn from the points whose MFPS normal is more than 3 degrees off (where
a refinement can gain). The target is the ground-truth normal in the point's canonical frame,
taken on the side of the (rotated) MFPS normal, as in the authors' code."""
from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Dict, List

import numpy as np

from .config import TrainConfig, descriptor_size

TEST_ONLY_PREFIXES = ("fandisk", "armadillo", "bunny", "cube")


def select_clouds(cfg: TrainConfig) -> List[dict]:
    """Clouds of the train split used for training: every model gets `levels_per_model` of the
    configured noise levels (cycled over the models, two apart), so all levels are covered at
    less cost; 0 (or at least as many as there are levels) keeps every level of every model."""
    index = json.loads((Path(cfg.data_dir) / "train" / "index.json").read_text())
    clouds = [c for c in index["clouds"] if c["variant"] in cfg.variants]
    for c in clouds:
        if c["model"].startswith(TEST_ONLY_PREFIXES) or c.get("test_only"):
            raise ValueError(f"test-only model {c['model']} in the training split")
    models = sorted({c["model"] for c in clouds})
    levels = list(cfg.noise_levels)
    per_model = cfg.levels_per_model if 0 < cfg.levels_per_model < len(levels) else len(levels)
    rounds: List[List[dict]] = [[] for _ in range(per_model)]
    for i, m in enumerate(models):
        if per_model == len(levels):
            want = levels
        else:
            want = list(dict.fromkeys(levels[(i + 2 * r) % len(levels)] for r in range(per_model)))
        for r, lev in enumerate(want):
            rounds[r] += [c for c in clouds if c["model"] == m and c["noise_percent"] == lev]
    # One cloud of every model first, then the second ones: a prefix (max_clouds) covers all models.
    chosen = [c for r in rounds for c in r]
    if cfg.max_clouds > 0:
        chosen = chosen[: cfg.max_clouds]
    return chosen


def cloud_samples(path_xyz: Path, path_normals: Path, cfg: TrainConfig, seed: int,
                  threads: int = 2) -> Dict[str, np.ndarray]:
    """Descriptors + targets of one cloud's sampled points."""
    import nhnet  # the core's bindings (build/python)

    points = np.loadtxt(path_xyz, dtype=np.float64, ndmin=2)
    gt = np.loadtxt(path_normals, dtype=np.float64, ndmin=2)
    d = nhnet.descriptors(points, threads=threads, seed=1)
    feats, rot, valid = d["features"], d["rotations"], d["valid"]
    mfps = d["normals"]
    cos = np.abs(np.sum(mfps * gt, axis=1)).clip(max=1.0)
    err = np.degrees(np.arccos(cos))
    rng = np.random.default_rng(seed)
    ok = np.flatnonzero(valid & np.isfinite(feats).all(axis=1))
    n_total = min(cfg.samples_per_cloud, ok.size)
    hard = ok[err[ok] > 3.0]
    n_hard = min(hard.size, n_total // 3)
    pick_hard = rng.choice(hard, n_hard, replace=False) if n_hard else np.empty(0, np.int64)
    rest = np.setdiff1d(ok, pick_hard)
    pick = np.concatenate([pick_hard, rng.choice(rest, n_total - n_hard, replace=False)])
    pick.sort()
    target = np.einsum("nij,nj->ni", rot[pick], gt[pick])
    self_rot = feats[pick, 0:3].astype(np.float64)
    target *= np.where(np.sum(target * self_rot, axis=1) < 0, -1.0, 1.0)[:, None]
    return {
        "features": feats[pick].astype(np.float32),
        "target": target.astype(np.float32),
        "mfps_error": err[pick].astype(np.float32),
    }


def core_fingerprint(version: int | None = None) -> str:
    """Short hash of the core's descriptors (MFPS normals included) on a fixed noisy corner cloud:
    it changes whenever the geometry stage or the descriptors change, so caches keyed by it are
    never reused across core versions (a stale cache once mixed two MFPS versions)."""
    import hashlib

    import nhnet

    rng = np.random.default_rng(7)
    faces = [np.c_[rng.random(200), rng.random(200), np.zeros(200)],
             np.c_[rng.random(200), np.zeros(200), rng.random(200)],
             np.c_[np.zeros(200), rng.random(200), rng.random(200)]]
    pts = np.concatenate(faces) + rng.normal(0, 0.004, (600, 3))
    version = nhnet.DESCRIPTOR_VERSION if version is None else version
    d = nhnet.descriptors(pts, threads=1, seed=1, version=version)
    h = hashlib.sha256(np.round(np.nan_to_num(d["features"]).astype(np.float64), 4).tobytes())
    # and the same corner under heavy noise, where the sizes are large and MFPS and the bandwidth
    # take spread subsets of their neighbourhoods (a change there leaves the light corner alone)
    loud = np.concatenate(faces) + rng.normal(0, 0.04, (600, 3))
    d = nhnet.descriptors(loud, threads=1, seed=1, version=version)
    h.update(np.round(np.nan_to_num(d["features"]).astype(np.float64), 4).tobytes())
    # and the noise probe on a clean curved cloud, where it sets the sizes of every stage (a probe
    # change that leaves the noisy corner's sizes alone moved those of detailed clouds)
    sphere = rng.normal(size=(2000, 3))
    sphere /= np.linalg.norm(sphere, axis=1, keepdims=True)
    h.update(np.round(nhnet.estimate(sphere, method="pca", threads=1, orient=None).noise_ratio,
                      4).tobytes())
    return f"v{version}-{h.hexdigest()[:10]}"


def build_dataset(cfg: TrainConfig, cache_dir: Path, log=print) -> Dict[str, np.ndarray]:
    """All selected clouds' samples, one cached .npz per cloud (re-runs reuse them), under a
    subfolder named by core_fingerprint()."""
    cache_dir = cache_dir / core_fingerprint()
    cache_dir.mkdir(parents=True, exist_ok=True)
    clouds = select_clouds(cfg)
    parts, names = [], []
    t0 = time.time()
    for i, c in enumerate(clouds):
        # Everything the cached samples depend on besides the core is in the name: a run with
        # another samples_per_cloud or seed computes its own (it once reused 4000-point files).
        seed = cfg.seed * 1000003 + i
        f = cache_dir / f"{c['name']}-n{cfg.samples_per_cloud}-r{seed}.npz"
        if not f.exists():
            folder = Path(cfg.data_dir) / "train"
            s = cloud_samples(folder / f"{c['name']}.xyz", folder / f"{c['name']}.normals", cfg,
                              seed=seed, threads=cfg.threads)
            tmp = f.with_suffix(".tmp.npz")
            np.savez(tmp, **s)
            os.replace(tmp, f)
        with np.load(f) as z:
            parts.append({k: z[k] for k in z.files})
        names.append(c["name"])
        log(f"[data] {i + 1}/{len(clouds)} {c['name']} ({time.time() - t0:.0f} s)")
    out = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    out["cloud"] = np.concatenate([np.full(len(p["target"]), j, np.int32) for j, p in enumerate(parts)])
    assert out["features"].shape[1] == descriptor_size()
    out["names"] = np.array(names)
    return out
