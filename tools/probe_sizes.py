#!/usr/bin/env python3
"""Why the automatic PCA size misses on some clouds: per cloud, the noise probe's ratio and the k
it picks, PCA's RMS at that k and at fixed K (the best K marked), and the probe's plane residual
at other sizes (low quantile / spacing, as core/src/geometry/scales.cpp measures it at 75).

    PYTHONPATH=build/python /usr/bin/python3 tools/probe_sizes.py CLOUD.gt.xyzn ...
        [--ks 12,18,30,50,100,200] [--probe 12,20,30,75] [--threads 2]

Noise makes the residual nearly flat in the probe size; curvature and small features make it
grow about linearly with it (residual ~ r^2 ~ k), so a cloud whose residual at 12 is a small
fraction of the one at 75 is read as noisy by its geometry. Needs numpy and scipy (cKDTree).
"""
from __future__ import annotations

import argparse
import math
import sys

import numpy as np

import nhnet

PROBE_QUANTILE = 0.25  # the core's kNoiseQuantile
PROBE_K = 75  # the core's kNoiseProbeK
SUBSET = 3000  # probed points per cloud (the core probes at most kProbeAllPoints)


def residual_ratios(points: np.ndarray, sizes: list[int]) -> list[float]:
    """Low quantile of the plane-fit residual RMS at each size, over the probe's spacing."""
    from scipy.spatial import cKDTree
    rows = points[:: max(1, len(points) // SUBSET)]
    kmax = max(max(sizes), PROBE_K)
    dist, idx = cKDTree(points).query(rows, kmax)
    spacing = np.median(dist[:, PROBE_K - 1]) * math.sqrt(math.pi / (PROBE_K - 1))
    out = []
    for k in sizes:
        p = points[idx[:, :k]]
        p = p - p.mean(axis=1, keepdims=True)
        smallest = np.linalg.eigvalsh(np.einsum("nki,nkj->nij", p, p) / k)[:, 0]
        rms = np.sqrt(np.maximum(smallest, 0.0))
        out.append(float(np.quantile(rms, PROBE_QUANTILE) / spacing))
    return out


def rms_at(points: np.ndarray, truth: np.ndarray, k: int, threads: int) -> tuple[float, int, float]:
    r = nhnet.estimate(points, method="pca", k=k, threads=threads, orient=None)
    return nhnet.metrics(r.normals, truth)["rms"], r.k_used, r.noise_ratio


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("clouds", nargs="+", help="clouds with true normals (.gt.xyzn)")
    ap.add_argument("--ks", default="12,18,30,50,100,200", help="fixed PCA sizes to score")
    ap.add_argument("--probe", default="12,20,30,75", help="probe sizes of the residual columns")
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    ks = [int(x) for x in a.ks.split(",")]
    sizes = [int(x) for x in a.probe.split(",")]
    print("| cloud | ratio | auto k | auto RMS | " + " | ".join(f"k={k}" for k in ks) + " | "
          + " | ".join(f"res@{s}" for s in sizes) + " |")
    print("|---|" + "---|" * (3 + len(ks) + len(sizes)))
    for path in a.clouds:
        try:
            cloud = np.loadtxt(path, ndmin=2)
        except (OSError, ValueError) as e:
            print(f"probe_sizes: {path}: {e}", file=sys.stderr)
            return 3
        pts, truth = cloud[:, :3], cloud[:, 3:6]
        auto, k_auto, ratio = rms_at(pts, truth, 0, a.threads)
        fixed = [rms_at(pts, truth, k, a.threads)[0] for k in ks]
        best = min(range(len(ks)), key=fixed.__getitem__)
        cells = [f"**{v:.2f}**" if i == best else f"{v:.2f}" for i, v in enumerate(fixed)]
        res = residual_ratios(pts, sizes)
        print(f"| {path.rsplit('/', 1)[-1].removesuffix('.gt.xyzn')} | {ratio:.3f} | {k_auto} | "
              f"{auto:.2f} | " + " | ".join(cells) + " | "
              + " | ".join(f"{v:.3f}" for v in res) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
