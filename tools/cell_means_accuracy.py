"""Accuracy and estimate time of dense noisy clouds with and without cell means (issue 23).

    PYTHONPATH=build/python:training /usr/bin/python3 tools/cell_means_accuracy.py \
        [--points 1000000] [--threads 2] [--method nhnet] [--orient mst] [--ratio R] [--means-only] MODEL:NOISE [...]

For every MODEL:NOISE (an nhnet-datagen model name and a noise level in % of the bounding-box
diagonal) it samples the model's clean surface (`sample_clean`, uniform), adds the noise
(`add_noise`, seed 1) and runs `nhnet.estimate` twice on the same points, unoriented:
`cell_means=False` (the points themselves) and `cell_means=True` (the default; `--ratio R`: from
noise ratio R instead, `cell_means=R`; a cloud under it runs once, not averaged; `--means-only`
skips the points' own run). Prints the noise
ratio, the means' count, the estimate's seconds and the unoriented angle error against the true
normals: RMS, mean, PGP5 / PGP10 and the share over 30 degrees. With `--orient mst` (or up) the
normals are oriented too, and the share of them whose sign agrees with the true (outward)
normal is printed.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import nhnet
from nhnet_training.datagen import add_noise, sample_clean


def errors(normals: np.ndarray, truth: np.ndarray) -> str:
    a = nhnet.angle_errors(normals, truth)
    a = a[np.isfinite(a)]
    return (f"RMS {np.sqrt(np.mean(a * a)):6.2f}  mean {a.mean():6.2f}  PGP5 {100 * np.mean(a < 5):5.1f}"
            f"  PGP10 {100 * np.mean(a < 10):5.1f}  >30 {100 * np.mean(a > 30):5.2f} %")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("clouds", nargs="+", help="MODEL:NOISE, e.g. fandisk:0.6")
    ap.add_argument("--points", type=int, default=1000000)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--method", default=None)
    ap.add_argument("--orient", default=None, choices=["mst", "up"])
    ap.add_argument("--means-only", action="store_true", help="skip the points' own estimate")
    ap.add_argument("--ratio", type=float, default=None,
                    help="noise ratio from which the second run averages (default: the core's)")
    args = ap.parse_args()
    for spec in args.clouds:
        model, level = spec.rsplit(":", 1)
        clean, truth = sample_clean(model, "uniform", args.points)[:2]
        points = add_noise(clean, float(level), 1)[0]
        for means in (True if args.ratio is None else args.ratio, False):
            start = time.perf_counter()
            r = nhnet.estimate(points, method=args.method, threads=args.threads,
                               orient=args.orient, cell_means=means)
            seconds = time.perf_counter() - start
            signs = ""
            if args.orient:
                agree = np.sum(r.normals * truth, axis=1) > 0
                signs = f"  signs right {100 * np.mean(agree[r.valid]):5.1f} %"
            print(f"{model:>20} {level:>4} %  noise ratio {r.noise_ratio:5.2f}  cell means "
                  f"{r.cell_means:7d}  k {r.k_used:3d}  {seconds:6.1f} s  {errors(r.normals, truth)}{signs}",
                  flush=True)
            if means is not False and (r.cell_means == 0 or args.means_only):
                break  # under the threshold: the points run would be the same one


if __name__ == "__main__":
    main()
