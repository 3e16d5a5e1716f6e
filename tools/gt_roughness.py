#!/usr/bin/env python3
"""How far the benchmark's true normals turn within one point spacing (issue 23).

A true normal is the normal of the mesh face its point was sampled from. Where a mesh has about
as many faces as the cloud has points (armadillo: 52 000 faces for 20 000 points), that normal
turns from one point to the next by angles the points cannot show, and every estimate that is
smooth over a spacing carries them as error. Per test point, the floor is the angle between its
true normal and the mean true normal of a dense sample of the same mesh within R spacings (same
side only: normals within 90 degrees of its own); per cloud its RMS.

    PYTHONPATH=training /usr/bin/python3 tools/gt_roughness.py floors \\
        --data data/generated/bench-20000/benchmark --out runs/roughness.jsonl
    /usr/bin/python3 tools/gt_roughness.py report runs/roughness.jsonl \\
        docs/benchmark/nhnet-v7/records.jsonl

`report` splits each cloud's RMS as floor^2 + rest^2 (the floor independent of what an estimator
gets wrong above it) and prints per category the floor, NH-Net's and PCL's best K's RMS and rest,
and how far below PCL's rest NH-Net's must fall for its RMS to be 20 % below PCL's.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
from nhnet_bench import pcl_best_k  # noqa: E402  (the bars' rule, one place)

DENSE_SAMPLES = 400_000  # mesh samples for the local mean normal (~20 per spacing disk at 20k)
RADII = (1.0, 2.0)       # in point spacings (median distance to the nearest other point)
BAR = 0.8                # issue 23: RMS at least 20 % below PCL's best K


def floor_angles(points: np.ndarray, normals: np.ndarray, dense_tree, dense_n: np.ndarray,
                 radius: float) -> np.ndarray:
    """Per point: degrees between its normal and the mean of the dense normals (their points in
    the kd-tree dense_tree) within radius that face its side (0 where none does)."""
    out = np.zeros(len(points))
    for i, idx in enumerate(dense_tree.query_ball_point(points, r=radius)):
        near = dense_n[idx]
        near = near[near @ normals[i] > 0]
        if len(near) == 0:
            continue
        m = near.sum(axis=0)
        c = abs(m @ normals[i]) / np.linalg.norm(m)
        out[i] = math.degrees(math.acos(min(1.0, c)))
    return out


def spacing(points: np.ndarray) -> float:
    from scipy.spatial import cKDTree

    d, _ = cKDTree(points).query(points, k=2)
    return float(np.median(d[:, 1]))


def cloud_floors(points: np.ndarray, normals: np.ndarray, mesh, seed: int = 7,
                 dense: int = DENSE_SAMPLES) -> dict:
    """RMS floor of one clean cloud at every radius of RADII, from its mesh (vertices, faces)."""
    from nhnet_training.datagen import sample_surface
    from scipy.spatial import cKDTree

    dense_p, dense_n, _ = sample_surface(mesh[0], mesh[1], dense, np.random.default_rng(seed))
    tree, s = cKDTree(dense_p), spacing(points)  # one tree for every radius
    return {f"floor_{r:g}": float(np.sqrt(np.mean(
        floor_angles(points, normals, tree, dense_n, r * s) ** 2))) for r in RADII}


def cmd_floors(args) -> None:
    from nhnet_training.meshes import load_model

    done: dict[tuple, dict] = {}  # (model, variant): the clean points are the same at every level
    with open(args.out, "w") as out:
        for gt in sorted(Path(args.data).glob("*/*.gt.xyzn")):
            name = gt.name[: -len(".gt.xyzn")]
            model, variant = name.rpartition("_noise")[0], "uniform"
            for v in ("gradient", "stripes"):
                if model.endswith("_" + v):
                    model, variant = model[: -len(v) - 1], v
            key = (model, variant)
            if key not in done:
                clean = np.loadtxt(gt.with_name(name + ".clean.xyz"), ndmin=2)
                normals = np.loadtxt(gt, ndmin=2)[:, 3:6]
                done[key] = cloud_floors(clean, normals, load_model(model))
            rec = {"cloud": name, "category": gt.parent.name, "model": model, **done[key]}
            out.write(json.dumps(rec) + "\n")
            print(json.dumps(rec), flush=True)


def best_k_rms(recs: list[dict]) -> tuple[dict[str, float], int]:
    """Per cloud: PCL's RMS at the category's best K (the benchmark's rule, pcl_best_k)."""
    k = pcl_best_k(recs)
    return {r["cloud"]: r["rms_deg"] for r in recs if r["k"] == k and "error" not in r}, k


def rest(rms: np.ndarray, floor: np.ndarray) -> np.ndarray:
    return np.sqrt(np.maximum(rms ** 2 - floor ** 2, 0.0))


def scale_needed(nh: np.ndarray, floor: np.ndarray, target: float) -> float:
    """The factor on NH-Net's rest per cloud that brings its mean RMS to target (bisection)."""
    lo, hi = 0.0, 1.0
    r = rest(nh, floor)
    if np.mean(np.sqrt(floor ** 2 + r ** 2)) <= target:
        return 1.0
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if np.mean(np.sqrt(floor ** 2 + (mid * r) ** 2)) <= target else (lo, mid)
    return lo


def cmd_report(args) -> None:
    floors = {r["cloud"]: r for r in (json.loads(line) for line in open(args.floors)
                                      if line.strip())}
    records = [json.loads(line) for line in open(args.records) if line.strip()]
    fkey = f"floor_{args.radius:g}"
    print(f"| category | clouds | floor (R = {args.radius:g} spacing) | NH-Net RMS / rest | "
          f"PCL best K RMS / rest | rest vs PCL | RMS bar | rest needed vs PCL |")
    print("|---|---|---|---|---|---|---|---|")
    for cat in dict.fromkeys(r["category"] for r in records):
        rs = [r for r in records if r["category"] == cat and "error" not in r]
        nh = {r["cloud"]: r["rms_deg"] for r in rs if r["method"] == "nhnet"}
        pcl, k = best_k_rms([r for r in rs if r["method"] == "pcl-pca"])
        clouds = [c for c in nh if c in pcl and c in floors]
        f = np.array([floors[c][fkey] for c in clouds])
        a, b = np.array([nh[c] for c in clouds]), np.array([pcl[c] for c in clouds])
        ra, rb = rest(a, f).mean(), rest(b, f).mean()
        s = scale_needed(a, f, BAR * b.mean())
        need = "met" if s >= 1.0 else f"{100 * (s * ra / rb - 1):+.1f} %"
        print(f"| {cat} | {len(clouds)} | {f.mean():.2f} | {a.mean():.2f} / {ra:.2f} | "
              f"{b.mean():.2f} / {rb:.2f} (k={k}) | {100 * (ra / rb - 1):+.1f} % | "
              f"{BAR * b.mean():.2f} | {need} |")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("floors", help="the floor of every cloud of a generated benchmark")
    f.add_argument("--data", required=True, help="a benchmark folder: CATEGORY/*.gt.xyzn")
    f.add_argument("--out", required=True)
    r = sub.add_parser("report", help="per category: floor, RMS and what the 20 % bar needs")
    r.add_argument("floors")
    r.add_argument("records", help="bench/nhnet_bench.py records.jsonl (nhnet and pcl-pca)")
    r.add_argument("--radius", type=float, default=RADII[0], choices=RADII)
    args = ap.parse_args(argv)
    {"floors": cmd_floors, "report": cmd_report}[args.cmd](args)


if __name__ == "__main__":
    sys.exit(main())
