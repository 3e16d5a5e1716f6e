#!/usr/bin/env python3
"""PCL NormalEstimationOMP at its best K per category on the test split (issue 23's bar: the
default's RMS >= 20 % below it in every category).

    /usr/bin/python3 tools/pcl_best_k.py [--data data/generated] [--ks 10,20,50,100,200]
        [--worker build/bench/nhnet-bench-worker]

Runs `nhnet-bench-worker pcl-pca K CLOUD.gt.xyzn` on every cloud of the generator's test split
(data/generated/benchmark/index.json) for every K; the worker scores all points of the cloud
(RMS and mean of the unoriented angle error). Per category, the K with the lowest RMS averaged
over the category's clouds (every cloud weighs the same, as tools/fit_candidate_mix.py report).
"""
from __future__ import annotations

import argparse
import json
import subprocess
from collections import defaultdict
from pathlib import Path


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default="data/generated")
    ap.add_argument("--ks", default="10,20,50,100,200")
    ap.add_argument("--worker", default="build/bench/nhnet-bench-worker")
    ap.add_argument("--threads", type=int, default=1)
    a = ap.parse_args()
    split = Path(a.data) / "benchmark"
    clouds = json.loads((split / "index.json").read_text())["clouds"]
    ks = [int(k) for k in a.ks.split(",")]
    rms = defaultdict(lambda: defaultdict(list))  # category -> k -> [(rms, mean)]
    for c in clouds:
        gt = split / c["files"][3]
        for k in ks:
            out = subprocess.run([a.worker, "pcl-pca", str(k), str(gt), "--threads", str(a.threads)],
                                 capture_output=True, text=True, check=True).stdout
            r = json.loads(out.strip().splitlines()[-1])
            rms[c["category"]][k].append((r["rms_deg"], r["mean_deg"]))
    print("| category | clouds | best K | PCL RMS | PCL mean |")
    print("|---|---|---|---|---|")
    for cat in sorted(rms):
        avg = {k: [sum(v[i] for v in rms[cat][k]) / len(rms[cat][k]) for i in (0, 1)] for k in ks}
        best = min(ks, key=lambda k: avg[k][0])
        print(f"| {cat} | {len(rms[cat][best])} | {best} | {avg[best][0]:.2f} | {avg[best][1]:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
