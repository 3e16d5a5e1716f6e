"""Error statistics of unoriented normal angles, as the benchmark reports them
(core/include/nhnet/eval/metrics.hpp: mean, RMS, PGP5, PGP10) plus the tail: the share of points
more than 30 degrees off (the normals that ruin a Poisson surface or a shading).

Used by training (validation, per noise level) and nhnet-evaluate (per category and noise level)."""
from __future__ import annotations

from typing import Dict, Iterable, List

import numpy as np

# Keys of angle_stats, in report order.
STAT_KEYS = ("rms", "mean", "pgp5", "pgp10", "over30")
TAIL_DEG = 30.0


def angle_stats(deg: Iterable[float]) -> Dict[str, float]:
    """RMS and mean (degrees), PGP5 / PGP10 / over30 (percent of points) of per-point angles."""
    a = np.asarray(deg, dtype=np.float64).ravel()
    if a.size == 0:
        return {k: float("nan") for k in STAT_KEYS} | {"count": 0}
    return {
        "rms": float(np.sqrt(np.mean(a * a))),
        "mean": float(a.mean()),
        "pgp5": float(100.0 * np.mean(a < 5.0)),
        "pgp10": float(100.0 * np.mean(a < 10.0)),
        "over30": float(100.0 * np.mean(a > TAIL_DEG)),
        "count": int(a.size),
    }


def mean_of_stats(rows: List[Dict[str, float]]) -> Dict[str, float]:
    """Average of per-cloud statistics (the benchmark's way: every cloud weighs the same)."""
    if not rows:
        return {k: float("nan") for k in STAT_KEYS} | {"count": 0}
    out = {k: float(np.mean([r[k] for r in rows])) for k in STAT_KEYS}
    out["count"] = len(rows)
    return out


def format_stats(s: Dict[str, float]) -> str:
    """One line: 'RMS 12.34 mean 8.90 PGP5 41.2 % PGP10 70.0 % >30 5.1 %'."""
    return (f"RMS {s['rms']:.3f} mean {s['mean']:.3f} PGP5 {s['pgp5']:.1f} % "
            f"PGP10 {s['pgp10']:.1f} % >30 {s['over30']:.2f} %")


def grouped_stats(deg: np.ndarray, groups: np.ndarray) -> Dict[str, Dict[str, float]]:
    """angle_stats per distinct group label (e.g. the noise level of each validation sample)."""
    deg, groups = np.asarray(deg), np.asarray(groups)
    return {str(g): angle_stats(deg[groups == g]) for g in sorted(set(groups.tolist()))}
