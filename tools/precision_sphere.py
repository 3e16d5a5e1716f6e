"""The default estimator's RMS angle error on noisy unit spheres, the network in float32 and in
bfloat16 (issue 23: whether bfloat16 may be the default).

    PYTHONPATH=build/python /usr/bin/python3 tools/precision_sphere.py [--threads 2]

Smooth surfaces with a few degrees of error are where bfloat16's rounding shows: the test split's
categories (RMS ~10 degrees) hide it. Prints, per cloud (points, noise as a fraction of the
radius), the RMS and mean error of the default and of the candidate mix without the learned fit.
"""

from __future__ import annotations

import argparse

import numpy as np

import nhnet

CLOUDS = [(20000, 0.021), (20000, 0.0), (100000, 0.0035)]  # 0.021 = 0.6 % of the diagonal


def errors(points: np.ndarray, truth: np.ndarray, threads: int, **options) -> tuple[float, float]:
    normals = nhnet.estimate(points, threads=threads, orient=None, **options).normals
    cos = np.abs((normals * truth).sum(axis=1)).clip(0, 1)
    deg = np.degrees(np.arccos(cos))
    return float(np.sqrt((deg ** 2).mean())), float(deg.mean())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    rng = np.random.default_rng(5)
    for n, noise in CLOUDS:
        truth = rng.normal(size=(n, 3))
        truth /= np.linalg.norm(truth, axis=1)[:, None]
        points = truth + rng.normal(scale=noise, size=(n, 3))
        for learned_fit in (True, False):
            cells = []
            for precision in nhnet.PRECISIONS:
                rms, mean = errors(points, truth, args.threads, precision=precision,
                                   learned_fit=learned_fit)
                cells.append(f"{precision} RMS {rms:.3f} mean {mean:.3f}")
            label = "default" if learned_fit else "mix only"
            print(f"{n} points, noise {noise}, {label}: " + ", ".join(cells))


if __name__ == "__main__":
    main()
