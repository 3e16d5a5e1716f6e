"""Fits the rho -> k table of core/src/geometry/scales.cpp from `calibrate_scales pca` output.

Each input line holds a cloud's noise ratio `rho=` and the RMS angle error of PCA at several
`k<K>=` values. Knots sit at fixed rho values; the k of each knot is chosen from a candidate
list by coordinate search so that the mean RMS over all clouds (error interpolated in log k,
k interpolated log-linearly in rho, as scales.cpp does) is smallest, keeping k non-decreasing.
Prints the knots and, for comparison, the mean RMS of the rule, of each fixed k and of a
per-cloud oracle.

Usage: python3 tools/fit_scale_table.py calib.txt [--knots 0.05,0.15,0.3,0.5,0.8,1.1,1.4]
       python3 tools/fit_scale_table.py calib.txt --evaluate 12,25,30,60,90,150,250
"""
import argparse
import math
import re

import numpy as np

CANDIDATES = [8, 10, 12, 15, 18, 22, 25, 30, 35, 40, 50, 60, 75, 90, 112, 130, 150, 175, 200,
              225, 250]


def load(path):
    rows = []
    for line in open(path):
        m = re.search(r"rho=([\d.]+)", line)
        if not m:
            continue
        ks = [(int(a), float(b)) for a, b in re.findall(r" k(\d+)=([\d.]+)", line)]
        rows.append((line.split()[0], float(m.group(1)), ks))
    return rows


def err_at(ks, k):
    return float(np.interp(math.log(k), [math.log(a) for a, _ in ks], [b for _, b in ks]))


def mean_rms(rows, xs, ys):
    logs = [math.log(y) for y in ys]
    return float(np.mean([err_at(ks, math.exp(np.interp(r, xs, logs))) for _, r, ks in rows]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("calib")
    ap.add_argument("--knots", default="0.05,0.15,0.3,0.5,0.8,1.1,1.4")
    ap.add_argument("--evaluate", help="k values at the knots (e.g. the shipped table): print "
                    "their mean RMS instead of fitting")
    args = ap.parse_args()
    rows = load(args.calib)
    xs = [float(x) for x in args.knots.split(",")]
    if args.evaluate:
        ys = [float(k) for k in args.evaluate.split(",")]
        print("table mean RMS over %d clouds: %.2f" % (len(rows), mean_rms(rows, xs, ys)))
        return
    ys = [25.0] * len(xs)
    for _ in range(4):
        for i in range(len(xs)):
            ys[i] = min(CANDIDATES, key=lambda c: mean_rms(rows, xs, ys[:i] + [c] + ys[i + 1:]))
        ys = list(np.maximum.accumulate(ys))
    print("clouds: %d" % len(rows))
    print("knots (rho, k): " + ", ".join("(%.2f, %d)" % (x, y) for x, y in zip(xs, ys)))
    print("rule mean RMS: %.2f" % mean_rms(rows, xs, ys))
    print("oracle mean RMS: %.2f" % np.mean([min(b for _, b in ks) for _, _, ks in rows]))
    for k, _ in rows[0][2]:
        print("fixed k=%d mean RMS: %.2f" % (k, np.mean([dict(ks)[k] for _, _, ks in rows])))


if __name__ == "__main__":
    main()
