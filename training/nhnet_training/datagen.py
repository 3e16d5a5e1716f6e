"""Deterministic benchmark / training point clouds with ground-truth normals.

Protocol: ``docs/design/benchmark-protocol.md#data``.  Points are sampled uniformly by area on
the triangles of the CGAL demo meshes; the ground-truth normal of a point is the unit normal
of the face it was sampled on; noise is Gaussian per coordinate with
``std = level / 100 * (bbox diagonal of the clean sampled cloud)``.

Everything is deterministic: the clean sample of a (model, variant) is drawn with seed
``base + crc32("sample|model|variant|points")`` and the noise of a (model, level, variant)
with ``base + crc32("noise|model|level|variant")`` (zlib.crc32, never Python's hash()).
So all noise levels of one model share the same clean points.

Command line::

    nhnet-datagen --out DIR [--set benchmark|train|sample|all] [--points N] [--subset]
                  [--seed S] [--categories A,B] [--models M1,M2] [--jobs J]

Output, per cloud, in ``DIR/benchmark/<category>/`` or ``DIR/train/``::

    <name>.xyz        noisy points "x y z" (%.9g), one per line
    <name>.normals    ground-truth unit normals "nx ny nz", same order
    <name>.clean.xyz  the clean points, same order
    <name>.gt.xyzn    noisy points + ground-truth normals "x y z nx ny nz"

and ``DIR/<set>/index.json`` listing every cloud.  ``--set sample`` writes the small demo
set committed under ``data/sample/`` straight into DIR.

Model tables (names of ``data/meshes/*.off`` in libcgal-demo's data.tar.gz)
----------------------------------------------------------------------------

============== =============================================================================
SharpFeature   fandisk rotor pinion anchor blade turbine spool oblong cube-meshed part joint
RichFeature    lion-head ChineseDragon-10kv mannequin-devil homer armadillo nefertiti dino
               triceratops
SmoothSurface  bunny00 elephant blobby camel bull femur knot1 mushroom
BigNoise       couplingdown dragknob cheese man cow hand retinal eight
PCPNetNoise    all 35 models above at 0 / 0.125 / 0.6 / 1.2 %
PCPNetDensity  all 35 models, variants 'gradient' and 'stripes', noise-free
train          see TRAIN_MODELS (35 models: 16 CAD, 19 organic, disjoint from the above and from their
               near-duplicates, none test-only)
============== =============================================================================
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import zlib
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import __version__
from .meshes import is_test_only, load_model

BASE_SEED = 20240613

# ----------------------------------------------------------------------------- tables

SHARP_FEATURE = ["fandisk", "rotor", "pinion", "anchor", "blade", "turbine", "spool",
                 "oblong", "cube-meshed", "part", "joint"]
RICH_FEATURE = ["lion-head", "ChineseDragon-10kv", "mannequin-devil", "homer", "armadillo",
                "nefertiti", "dino", "triceratops"]
SMOOTH_SURFACE = ["bunny00", "elephant", "blobby", "camel", "bull", "femur", "knot1",
                  "mushroom"]
BIG_NOISE = ["couplingdown", "dragknob", "cheese", "man", "cow", "hand", "retinal", "eight"]

# category -> (models, noise levels in percent of the bbox diagonal)
BENCHMARK_CATEGORIES: dict[str, tuple[list[str], list[float]]] = {
    "SharpFeature": (SHARP_FEATURE, [0.05, 0.1, 0.15]),
    "RichFeature": (RICH_FEATURE, [0.05, 0.1, 0.15, 0.2]),
    "SmoothSurface": (SMOOTH_SURFACE, [0.05, 0.1, 0.15]),
    "BigNoise": (BIG_NOISE, [0.2, 0.3, 0.4, 0.5]),
}
BENCHMARK_MODELS = SHARP_FEATURE + RICH_FEATURE + SMOOTH_SURFACE + BIG_NOISE
PCPNET_LEVELS = [0.0, 0.125, 0.6, 1.2]
DENSITY_VARIANTS = ["gradient", "stripes"]
BENCHMARK_DENSITY_LEVEL = 0.0  # PCPNet's varying-density sets are noise-free

# Other meshes in the tarball that are the same shape as a benchmark model (re-meshings,
# shuffled copies, sub-parts): never used for training either.
NEAR_DUPLICATES = [
    "anchor_dense", "rotor_small", "pinion_small", "oblong-shuffled", "blobby-shuffled",
    "blobby_3cc", "elephant-with-holes", "refined_elephant", "lion", "knot", "knot2",
    "cheese-box", "fandisk-box", "fandisk_large",
]

# Training models: disjoint from the benchmark; CAD-like (sharp) ones first, then organic.
TRAIN_CAD = [
    "b9_mesh", "polygon_mesh", "mech-holes-shark", "ALSTOM_TEST4", "tripod", "cross",
    "star", "u", "P", "torus_quad", "double-torus-example", "pipe", "quint_tris",
    "icosahedron", "octahedron", "prim",
]
TRAIN_ORGANIC = [
    "bear", "diplodocus", "elk", "handle", "head", "pig", "cactus", "helmet", "bones",
    "mask_cone", "three_peaks", "holes",
    # 2026-12-03 (issue 23: at least as many organic shapes as CAD; models up to v6 had the 12
    # above): terrain, a second scan of the bear statue, smooth closed and open surfaces.
    "horizons", "bear_bis", "ellipe0.003", "larger_sphere", "patch-01", "patch-20", "patch-30",
]
TRAIN_MODELS = TRAIN_CAD + TRAIN_ORGANIC
TRAIN_LEVELS = [0.0, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 1.2]
TRAIN_DENSITY_LEVELS = [0.0, 0.3]

SAMPLE_MODEL, SAMPLE_LEVEL, SAMPLE_POINTS = "fandisk", 0.6, 20000

DEFAULT_POINTS = {"benchmark": 100000, "train": 50000}
SUBSET_POINTS = 10000
SUBSET_MODELS_PER_CATEGORY = 2


def _check_splits() -> None:
    bench = set(BENCHMARK_MODELS)
    train = set(TRAIN_MODELS)
    assert len(bench) == len(BENCHMARK_MODELS) == 35, "benchmark models must be 35 distinct"
    assert len(train) == len(TRAIN_MODELS), "duplicate training model"
    assert not (train & bench), f"train and benchmark overlap: {sorted(train & bench)}"
    assert not (train & set(NEAR_DUPLICATES)), "near-duplicate of a benchmark model in train"
    bad = [m for m in TRAIN_MODELS if is_test_only(m)]
    assert not bad, f"test-only models in the training split: {bad}"
    assert len(TRAIN_ORGANIC) >= len(TRAIN_CAD), "fewer organic than CAD training models"


_check_splits()


# ----------------------------------------------------------------------------- sampling

def stable_seed(*parts, base: int = BASE_SEED) -> int:
    """Seed from a fixed base and a stable hash (zlib.crc32) of the parts."""
    key = "|".join(_fmt_level(p) if isinstance(p, float) else str(p) for p in parts)
    return (base + zlib.crc32(key.encode("utf-8"))) % (2 ** 63)


def _fmt_level(x: float) -> str:
    return f"{x:g}"


def face_normals_areas(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    cr = np.cross(b - a, c - a)
    dbl = np.linalg.norm(cr, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        n = cr / dbl[:, None]
    return n, 0.5 * dbl


def valid_faces(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Indices of non-degenerate faces (distinct vertices, area > 1e-12 of the largest)."""
    n, area = face_normals_areas(v, f)
    ok = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    ok &= np.isfinite(area) & np.all(np.isfinite(n), axis=1)
    if ok.any():
        ok &= area > 1e-12 * area[ok].max()
    return np.nonzero(ok)[0]


def sample_surface(v: np.ndarray, f: np.ndarray, n_points: int, rng: np.random.Generator,
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Uniform-by-area samples: (points (N,3), unit normals (N,3), face ids (N,))."""
    keep = valid_faces(v, f)
    if keep.size == 0:
        raise ValueError("mesh has no non-degenerate face")
    fn, area = face_normals_areas(v, f[keep])
    cdf = np.cumsum(area)
    cdf /= cdf[-1]
    u = rng.random(n_points)
    k = np.minimum(np.searchsorted(cdf, u, side="right"), keep.size - 1)
    r1 = np.sqrt(rng.random(n_points))
    r2 = rng.random(n_points)
    tri = f[keep[k]]
    a, b, c = v[tri[:, 0]], v[tri[:, 1]], v[tri[:, 2]]
    w0 = (1.0 - r1)[:, None]
    w1 = (r1 * (1.0 - r2))[:, None]
    w2 = (r1 * r2)[:, None]
    pts = w0 * a + w1 * b + w2 * c
    return pts, fn[k], keep[k]


def density_keep_probability(points: np.ndarray, variant: str, lo: float, hi: float,
                             ) -> np.ndarray:
    """Keep probability of each point for a density variant, along x in [lo, hi]."""
    t = (points[:, 0] - lo) / max(hi - lo, 1e-300)
    t = np.clip(t, 0.0, 1.0)
    if variant == "gradient":
        return 1.0 - 0.9 * t  # 1 at min x, 0.1 at max x
    if variant == "stripes":
        slab = np.minimum((t * 10).astype(np.int64), 9)  # 10 slabs along x
        return np.where(slab % 2 == 0, 1.0, 0.1)  # odd slabs keep only 10 %
    raise ValueError(f"unknown density variant {variant!r}")


def sample_clean(model: str, variant: str, n_points: int, base_seed: int = BASE_SEED,
                 mesh: tuple[np.ndarray, np.ndarray] | None = None):
    """Clean cloud of a model: (points, normals, face ids, seed)."""
    v, f = mesh if mesh is not None else load_model(model)
    seed = stable_seed("sample", model, variant, n_points, base=base_seed)
    rng = np.random.default_rng(seed)
    if variant == "uniform":
        p, n, fid = sample_surface(v, f, n_points, rng)
        return p, n, fid, seed
    lo, hi = float(v[:, 0].min()), float(v[:, 0].max())
    got_p, got_n, got_f, have = [], [], [], 0
    batch = max(2 * n_points, 1024)
    while have < n_points:  # i.i.d. samples thinned: the first n_points kept are unbiased
        p, n, fid = sample_surface(v, f, batch, rng)
        keep = rng.random(batch) < density_keep_probability(p, variant, lo, hi)
        got_p.append(p[keep]); got_n.append(n[keep]); got_f.append(fid[keep])
        have += int(keep.sum())
    p = np.concatenate(got_p)[:n_points]
    n = np.concatenate(got_n)[:n_points]
    fid = np.concatenate(got_f)[:n_points]
    return p, n, fid, seed


def bbox_diagonal(points: np.ndarray) -> float:
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))


def add_noise(clean: np.ndarray, level_percent: float, seed: int) -> tuple[np.ndarray, float]:
    """Gaussian noise per coordinate, std = level % of the clean cloud's bbox diagonal."""
    std = level_percent / 100.0 * bbox_diagonal(clean)
    if std == 0.0:
        return clean.copy(), 0.0
    rng = np.random.default_rng(seed)
    return clean + rng.normal(0.0, std, size=clean.shape), std


# ----------------------------------------------------------------------------- writing

def format_rows(a: np.ndarray) -> list[str]:
    """Rows of a (N,k) float array as '%.9g' strings joined by spaces (fast)."""
    k = a.shape[1]
    s = (("%.9g " * (k - 1) + "%.9g\n") * a.shape[0]) % tuple(a.ravel().tolist())
    return s.split("\n")[:-1]


def _write_text(path: Path, lines: list[str]) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", encoding="ascii", newline="\n") as fh:
        fh.write("\n".join(lines))
        fh.write("\n")
    os.replace(tmp, path)


def write_cloud(stem: Path, noisy: np.ndarray, normals: np.ndarray, clean: np.ndarray | None,
                files: tuple[str, ...] = ("xyz", "normals", "clean.xyz", "gt.xyzn"),
                ) -> list[str]:
    stem.parent.mkdir(parents=True, exist_ok=True)
    xyz = format_rows(noisy)
    nrm = format_rows(normals)
    written = []
    for kind in files:
        path = stem.with_name(f"{stem.name}.{kind}")
        if kind == "xyz":
            _write_text(path, xyz)
        elif kind == "normals":
            _write_text(path, nrm)
        elif kind == "clean.xyz":
            _write_text(path, xyz if clean is noisy else format_rows(clean))
        elif kind == "gt.xyzn":
            _write_text(path, [a + " " + b for a, b in zip(xyz, nrm)])
        else:
            raise ValueError(kind)
        written.append(path.name)
    return written


# ----------------------------------------------------------------------------- plans

@dataclass
class Job:
    """One (model, variant) clean sample and the noise levels made from it."""
    model: str
    variant: str
    points: int
    outputs: list[tuple[str, float]] = field(default_factory=list)  # (category, level)


def cloud_name(model: str, level: float, variant: str) -> str:
    v = "" if variant == "uniform" else f"_{variant}"
    return f"{model}{v}_noise{_fmt_level(level)}"


def plan_benchmark(points: int, subset: bool, categories: set[str] | None = None,
                   models: set[str] | None = None) -> list[Job]:
    jobs: dict[tuple[str, str], Job] = {}

    def add(model, variant, category, level):
        if categories and category not in categories:
            return
        if models and model not in models:
            return
        j = jobs.setdefault((model, variant), Job(model, variant, points))
        j.outputs.append((category, level))

    pick = (lambda ms: ms[:SUBSET_MODELS_PER_CATEGORY]) if subset else (lambda ms: ms)
    all_models = []
    for cat, (cat_models, levels) in BENCHMARK_CATEGORIES.items():
        for m in pick(cat_models):
            all_models.append(m)
            for lv in levels:
                add(m, "uniform", cat, lv)
    for m in all_models:
        for lv in PCPNET_LEVELS:
            add(m, "uniform", "PCPNetNoise", lv)
        for var in DENSITY_VARIANTS:
            add(m, var, "PCPNetDensity", BENCHMARK_DENSITY_LEVEL)
    return list(jobs.values())


def plan_train(points: int, subset: bool) -> list[Job]:
    models = TRAIN_MODELS[:2] + TRAIN_MODELS[16:18] if subset else TRAIN_MODELS
    jobs = []
    for m in models:
        assert not is_test_only(m) and m not in BENCHMARK_MODELS
        jobs.append(Job(m, "uniform", points, [("train", lv) for lv in TRAIN_LEVELS]))
        for var in DENSITY_VARIANTS:
            jobs.append(Job(m, var, points, [("train", lv) for lv in TRAIN_DENSITY_LEVELS]))
    return jobs


def run_job(job: Job, set_dir: str, base_seed: int, flat: bool = False,
            files: tuple[str, ...] = ("xyz", "normals", "clean.xyz", "gt.xyzn")) -> list[dict]:
    v, f = load_model(job.model)
    mesh_diag = bbox_diagonal(v[np.unique(f)]) if f.size else bbox_diagonal(v)
    clean, normals, _fid, sample_seed = sample_clean(job.model, job.variant, job.points,
                                                     base_seed, (v, f))
    diag = bbox_diagonal(clean)
    entries = []
    for category, level in job.outputs:
        seed = stable_seed("noise", job.model, float(level), job.variant, base=base_seed)
        noisy, std = add_noise(clean, level, seed)
        if std == 0.0:
            noisy = clean
        name = cloud_name(job.model, level, job.variant)
        rel_dir = Path(".") if flat else Path(category)
        written = write_cloud(Path(set_dir) / rel_dir / name, noisy, normals, clean, files)
        entries.append({
            "name": name,
            "model": job.model,
            "category": category,
            "noise_percent": level,
            "variant": job.variant,
            "points": int(clean.shape[0]),
            "bbox_diagonal": diag,
            "mesh_bbox_diagonal": mesh_diag,
            "noise_std": std,
            "seed": seed,
            "sample_seed": sample_seed,
            "test_only": is_test_only(job.model),
            "files": [str(rel_dir / w) if not flat else w for w in written],
        })
    return entries


def _run_job_star(args):
    return run_job(*args)


def generate(out: str | os.PathLike, which: str, points: int | None = None,
             subset: bool = False, base_seed: int = BASE_SEED,
             categories: set[str] | None = None, jobs: int | None = None,
             log=print, models: set[str] | None = None) -> dict:
    """Generate one set ('benchmark', 'train' or 'sample'); returns the index written."""
    out = Path(out)
    files: tuple[str, ...] = ("xyz", "normals", "clean.xyz", "gt.xyzn")
    flat = False
    if which == "sample":
        n = points or SAMPLE_POINTS
        plan = [Job(SAMPLE_MODEL, "uniform", n, [("sample", SAMPLE_LEVEL)])]
        set_dir = out
        flat = True
        files = ("xyz", "gt.xyzn", "clean.xyz")  # clean points: denoising accuracy
    else:
        n = points or (SUBSET_POINTS if subset else DEFAULT_POINTS[which])
        plan = plan_benchmark(n, subset, categories, models) if which == "benchmark" \
            else plan_train(n, subset)
        set_dir = out / which
        flat = which == "train"  # one category: DIR/train/<name>.*
        if which == "train":
            models = {j.model for j in plan}
            assert not (models & set(BENCHMARK_MODELS)), "train/benchmark overlap"
            assert not any(is_test_only(m) for m in models), "test-only model in train"
    set_dir.mkdir(parents=True, exist_ok=True)
    # Big jobs first so the pool stays busy; the index is sorted afterwards.
    plan.sort(key=lambda j: -len(j.outputs))
    t0 = time.time()
    nproc = max(1, jobs or os.cpu_count() or 1)
    args = [(j, str(set_dir), base_seed, flat, files) for j in plan]
    entries: list[dict] = []
    if nproc == 1 or len(plan) == 1:
        for a in args:
            entries += run_job(*a)
    else:
        with ProcessPoolExecutor(max_workers=nproc) as ex:
            for res in ex.map(_run_job_star, args):
                entries += res
    entries.sort(key=lambda e: (e["category"], e["model"], e["variant"], e["noise_percent"]))
    index = {
        "generator": f"nhnet-datagen {__version__}",
        "set": which,
        "base_seed": base_seed,
        "points_per_cloud": n,
        "subset": subset,
        "noise": "gaussian per coordinate, std = noise_percent/100 * bbox_diagonal "
                 "(bbox of the clean sampled cloud)",
        "ground_truth": "unit normal of the sampled face (mesh winding)",
        "clouds": entries,
    }
    with open(set_dir / "index.json", "w", encoding="ascii", newline="\n") as fh:
        json.dump(index, fh, indent=1)
        fh.write("\n")
    log(f"nhnet-datagen: {which}: {len(entries)} clouds x {n} points -> {set_dir} "
        f"({time.time() - t0:.1f} s)")
    return index


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="nhnet-datagen",
        description="Deterministic benchmark/training point clouds with ground-truth normals, "
                    "sampled from the CGAL demo meshes (libcgal-demo).")
    ap.add_argument("--out", required=False, help="output directory")
    ap.add_argument("--set", dest="which", default="benchmark",
                    choices=["benchmark", "train", "sample", "all"],
                    help="which set ('all' = benchmark + train); default benchmark")
    ap.add_argument("--points", type=int, default=None,
                    help=f"points per cloud (default: benchmark {DEFAULT_POINTS['benchmark']}, "
                         f"train {DEFAULT_POINTS['train']}, sample {SAMPLE_POINTS}, "
                         f"--subset {SUBSET_POINTS})")
    ap.add_argument("--subset", action="store_true",
                    help=f"quick subset: {SUBSET_MODELS_PER_CATEGORY} models per category, "
                         f"{SUBSET_POINTS} points")
    ap.add_argument("--seed", type=int, default=BASE_SEED, help="base seed")
    ap.add_argument("--categories", default=None,
                    help="benchmark only: comma-separated categories to make "
                         "(SharpFeature,RichFeature,SmoothSurface,BigNoise,PCPNetNoise,"
                         "PCPNetDensity)")
    ap.add_argument("--models", default=None,
                    help="benchmark only: comma-separated models to make (e.g. fandisk,bunny00); "
                         "default all of each category")
    ap.add_argument("--jobs", type=int, default=None, help="worker processes (default: CPUs)")
    ap.add_argument("--list", action="store_true", help="print the model splits and exit")
    a = ap.parse_args(argv)
    if a.list:
        for cat, (models, levels) in BENCHMARK_CATEGORIES.items():
            print(f"{cat:14s} noise {levels}: {' '.join(models)}")
        print(f"{'PCPNetNoise':14s} noise {PCPNET_LEVELS}: all {len(BENCHMARK_MODELS)} above")
        print(f"{'PCPNetDensity':14s} {DENSITY_VARIANTS} at noise {BENCHMARK_DENSITY_LEVEL}")
        print(f"{'train':14s} noise {TRAIN_LEVELS}, {DENSITY_VARIANTS} at "
              f"{TRAIN_DENSITY_LEVELS}: {' '.join(TRAIN_MODELS)}")
        print(f"{'excluded':14s} near-duplicates of benchmark models: {' '.join(NEAR_DUPLICATES)}")
        return 0
    if not a.out:
        ap.error("--out is required")
    if a.points is not None and a.points <= 0:
        ap.error("--points must be positive")
    cats = None
    if a.categories:
        cats = {c.strip() for c in a.categories.split(",") if c.strip()}
        known = set(BENCHMARK_CATEGORIES) | {"PCPNetNoise", "PCPNetDensity"}
        if cats - known:
            ap.error(f"unknown categories: {sorted(cats - known)}")
    models = None
    if a.models:
        models = {m.strip() for m in a.models.split(",") if m.strip()}
        if models - set(BENCHMARK_MODELS):
            ap.error(f"not benchmark models: {sorted(models - set(BENCHMARK_MODELS))}")
    sets = ["benchmark", "train"] if a.which == "all" else [a.which]
    t0 = time.time()
    for s in sets:
        generate(a.out, s, a.points, a.subset, a.seed, cats if s == "benchmark" else None,
                 a.jobs, models=models if s == "benchmark" else None)
    if len(sets) > 1:
        print(f"nhnet-datagen: total {time.time() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
