"""Benchmark subset evaluation of NH-Net against MFPS, both from one core call per cloud.

`nhnet.descriptors` returns the MFPS normals (the geometry stage, = `nhnet-cli estimate --method
mfps`) and the descriptors; the exported TorchScript model (= what `nhnet-cli estimate --method
nhnet` runs; tests/core/test_nhnet_model.cpp checks C++ == Python) refines them. Errors are the
unoriented angles to the ground truth (as `nhnet-cli eval`), on a fixed random subset of each
cloud's points (the whole cloud is processed); reported as RMS, mean, PGP5/PGP10 and the share
over 30 degrees, per category and per noise level (metrics.py).

    nhnet-evaluate --data-dir data/generated --model models/nhnet.pt --per-category 3

`--default` adds each model as the default method runs it: the whole cloud through the core's
pipeline (`nhnet.estimate_normals(method="nhnet", model=M)`: the network, then the candidate mix
whose weights were fitted to the shipped model's outputs), scored at the same points.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import torch

from .config import DESCRIPTOR_VERSION
from .export import META_NAME
from .metrics import angle_stats, mean_of_stats


def pick_clouds(data_dir: str, per_category: int, categories=None, names=None):
    index = json.loads((Path(data_dir) / "benchmark" / "index.json").read_text())
    if names:
        by_name = {c["name"]: c for c in index["clouds"]}
        return [by_name[n] for n in names]
    by_cat = {}
    for c in index["clouds"]:
        by_cat.setdefault(c["category"], []).append(c)
    out = []
    for cat in sorted(by_cat):
        if categories and cat not in categories:
            continue
        cl = sorted(by_cat[cat], key=lambda c: c["name"])
        take = min(per_category, len(cl))  # (per_category > len(cl) once repeated clouds)
        step = len(cl) / take
        out += [cl[int(i * step + step / 2)] for i in range(take)]
    return out


def cloud_data(data_dir: str, c: dict, points: int, cache: Path, threads: int, version: int):
    """The cloud's descriptors of `version` (a model's descriptor_version) at fixed rows, with
    the MFPS, pca-auto and true normals there; computed once, then read from `cache`."""
    f = cache / f"{c['name']}.npz"
    if not f.exists():  # stored with at least the default 20 000 rows, subsets taken below
        _compute_cloud(data_dir, c, max(points, 20000), f, threads, version)
    with np.load(f) as z:
        d = {k: z[k] for k in z.files}
    d["pca"] = pca_auto(data_dir, c, d["rows"], f.with_suffix(".pca-auto.npy"), threads)
    if len(d["rows"]) > points:  # a fixed subset of the stored rows
        keep = np.sort(np.random.default_rng(12345).choice(len(d["rows"]), points, replace=False))
        for k in ("rows", "features", "rotations", "mfps", "gt", "valid", "pca"):
            d[k] = d[k][keep]
    return d


def pca_auto(data_dir: str, c: dict, rows: np.ndarray, f: Path, threads: int) -> np.ndarray:
    """The core's PCA with the noise-driven k (bench's pca-auto, `--method pca`) on the whole
    cloud, at the stored rows; cached next to the descriptors."""
    if not f.exists():
        import nhnet

        xyz = np.loadtxt(Path(data_dir) / "benchmark" / c["files"][0], ndmin=2)
        n = nhnet.estimate_normals(xyz, method="pca", k=0, threads=threads)[rows]
        np.save(f.with_suffix(".tmp.npy"), n)
        f.with_suffix(".tmp.npy").replace(f)
    return np.load(f)


def _compute_cloud(data_dir: str, c: dict, points: int, f: Path, threads: int,
                   version: int) -> None:
    import nhnet

    base = Path(data_dir) / "benchmark"
    xyz = np.loadtxt(base / c["files"][0], ndmin=2)
    gt = np.loadtxt(base / c["files"][1], ndmin=2)
    t0 = time.time()
    d = nhnet.descriptors(xyz, threads=threads, version=version)
    secs = time.time() - t0
    rng = np.random.default_rng(12345)
    rows = np.sort(rng.choice(len(xyz), min(points, len(xyz)), replace=False))
    out = {"rows": rows, "features": d["features"][rows], "rotations": d["rotations"][rows],
           "mfps": d["normals"][rows], "gt": gt[rows], "valid": d["valid"][rows],
           "seconds": np.array(secs), "n": np.array(len(xyz))}
    f.parent.mkdir(parents=True, exist_ok=True)
    np.savez(f.with_suffix(".tmp.npz"), **out)
    f.with_suffix(".tmp.npz").replace(f)


def default_normals(data_dir: str, c: dict, model: str, threads: int) -> np.ndarray:
    """The default method's normals of the whole cloud with `model` (network and candidate mix,
    unoriented), as `nhnet-cli estimate --model MODEL` computes them."""
    import nhnet

    xyz = np.loadtxt(Path(data_dir) / "benchmark" / c["files"][0], ndmin=2)
    return nhnet.estimate_normals(xyz, method="nhnet", model=model, threads=threads, orient=None)


def model_and_version(path: str):
    """(TorchScript module, the descriptor version in its metadata), from one read of the file."""
    extra = {META_NAME: ""}
    module = torch.jit.load(path, _extra_files=extra).eval()
    meta = json.loads(extra[META_NAME] or "{}")
    return module, int(meta.get("descriptor_version", DESCRIPTOR_VERSION))


def angles(n, gt):
    cos = np.abs(np.sum(n * gt, axis=1)) / (np.linalg.norm(n, axis=1) * np.linalg.norm(gt, axis=1))
    return np.degrees(np.arccos(np.clip(cos, 0, 1)))


def refine(model, d, batch=4096):
    x = torch.from_numpy(np.ascontiguousarray(d["features"], dtype=np.float32))
    ok = np.isfinite(d["features"]).all(axis=1)
    local = np.full((len(x), 3), np.nan)
    with torch.no_grad():
        idx = np.flatnonzero(ok)
        for i in range(0, len(idx), batch):
            j = idx[i:i + batch]
            local[j] = model(x[j]).double().numpy()
    world = np.einsum("nji,nj->ni", d["rotations"], local)  # R^T y
    return np.where(ok[:, None], world, d["mfps"])


def report(rows, names) -> str:
    """Markdown tables: RMS / mean / PGP5 / PGP10 / share over 30 degrees of every method, per
    category and per noise level (+ density variant), each the mean of the clouds' figures (the
    benchmark's way)."""
    def table(title, key_of):
        keys = sorted({key_of(r) for r in rows}, key=str) + ["all"]
        head = " | ".join(f"{n} {k}" for n in names for k in ("RMS", "mean", "PGP5", "PGP10", ">30"))
        out = [f"\n{title}\n", f"| {title.split()[-1]} | clouds | {head} |",
               "|---|---|" + "---|" * (5 * len(names))]
        for key in keys:
            rs = [r for r in rows if key == "all" or key_of(r) == key]
            cells = []
            for n in names:
                st = mean_of_stats([r[n] for r in rs])
                cells += [f"{st['rms']:.2f}", f"{st['mean']:.2f}", f"{st['pgp5']:.1f}",
                          f"{st['pgp10']:.1f}", f"{st['over30']:.2f}"]
            out.append(f"| {key} | {len(rs)} | " + " | ".join(cells) + " |")
        return "\n".join(out)

    return (table("Per category", lambda r: r["category"]) + "\n"
            + table("Per noise level", lambda r: f"{r['noise']}%"
                    + ("" if r["variant"] == "uniform" else " " + r["variant"])))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="nhnet-evaluate", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data-dir", default="data/generated")
    ap.add_argument("--model", nargs="*", default=[], help="TorchScript model(s) to compare")
    ap.add_argument("--per-category", type=int, default=3)
    ap.add_argument("--categories", nargs="*")
    ap.add_argument("--clouds", nargs="*", help="these benchmark clouds instead of a per-category pick")
    ap.add_argument("--points", type=int, default=20000, help="evaluated points per cloud")
    ap.add_argument("--cache", default="runs/bench_cache")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--json", default="", help="write the per-cloud results here")
    ap.add_argument("--default", action="store_true",
                    help="also each model as the default method runs it (the whole cloud through "
                         "`--method nhnet --model M`: the network, then the candidate mix)")
    a = ap.parse_args(argv)
    torch.set_num_threads(a.threads)
    models = [(Path(m).parent.name + "/" + Path(m).stem,) + model_and_version(m) for m in a.model]
    paths = dict(zip([n for n, _, _ in models], a.model))
    from .dataset import core_fingerprint
    versions = sorted({v for _, _, v in models} or {DESCRIPTOR_VERSION})
    # descriptors of this core version only, one cache per descriptor version
    caches = {v: Path(a.cache) / core_fingerprint(v) for v in versions}
    rows = []
    for c in pick_clouds(a.data_dir, a.per_category, a.categories, a.clouds):
        data = {v: cloud_data(a.data_dir, c, a.points, caches[v], a.threads, v) for v in versions}
        d = data[versions[0]]
        r = {"cloud": c["name"], "category": c["category"], "noise": c["noise_percent"],
             "variant": c["variant"], "mfps": angle_stats(angles(d["mfps"], d["gt"])),
             "pca-auto": angle_stats(angles(d["pca"], d["gt"]))}
        for name, m, v in models:
            t0 = time.time()
            d = data[v]
            r[name] = angle_stats(angles(refine(m, d), d["gt"]))
            r[name]["pts_per_s"] = len(d["features"]) / (time.time() - t0)
            if a.default:
                r[name + " default"] = angle_stats(angles(
                    default_normals(a.data_dir, c, paths[name], a.threads)[d["rows"]], d["gt"]))
        rows.append(r)
        print(json.dumps(r), flush=True)
    names = ["pca-auto", "mfps"] + [n for n, _, _ in models]
    names += [n + " default" for n, _, _ in models] if a.default else []
    print(report(rows, names))
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
