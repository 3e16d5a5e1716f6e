"""Whole-process time of two nhnet-cli builds against PCL, interleaved (issue 23).

    /usr/bin/python3 tools/ab_timing.py --a OLD/nhnet-cli --b NEW/nhnet-cli [--b-args ARGS] \
        --worker build/bench/nhnet-bench-worker [--reps 2] [--threads 2] [--tmp DIR] \
        CLOUD.gt.xyzn [...] [-- extra nhnet-cli estimate arguments]

For every cloud (an nhnet-datagen `.gt.xyzn`; its coordinates are written once to DIR/NAME.xyz,
the input of nhnet-cli) it runs, rep after rep: PCL, A, PCL, B, and one PCL at the end, each in
its own process, so on a shared machine A and B meet the same load. A and B are the whole
`nhnet-cli estimate IN OUT` command (read, estimate, orient, write); PCL is
`nhnet-bench-worker pcl-pca 50 CLOUD --threads T`, timed as a process (reading the cloud and
scoring it included) and by its own estimator clock. Wall and CPU (user + system) seconds:
on a loaded machine the CPU seconds move less than the wall time. Prints one line per run and a markdown table
of the medians, each nhnet time also as a ratio to the median PCL process time, and the load
average seen before the runs. Checks that A and B wrote the same normals (max |difference| per
component; the golden tolerance is 1e-6).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path


def xyz_of(gt: Path, tmp: Path) -> Path:
    out = tmp / (gt.name[: -len(".gt.xyzn")] + ".xyz")
    if not out.exists():
        with open(gt) as f, open(out, "w") as g:
            for line in f:
                g.write(" ".join(line.split()[:3]) + "\n")
    return out


def run(cmd: list[str]) -> tuple[float, float, str]:
    """Wall seconds, CPU seconds (user + system, the reaped child's rusage) and stdout of one
    child; children run one at a time, so the RUSAGE_CHILDREN difference is this one's."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        sys.exit(f"failed ({done.returncode}): {' '.join(cmd)}\n{done.stderr[-2000:]}")
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return wall, cpu, done.stdout


def normals(path: Path) -> list[list[float]]:
    rows = []
    with open(path) as f:
        for line in f:
            v = line.split()
            if len(v) >= 6:
                rows.append([float(x) for x in v[3:6]])
    return rows


def max_difference(a: Path, b: Path) -> float:
    na, nb = normals(a), normals(b)
    if len(na) != len(nb):
        return float("inf")
    return max((abs(x - y) for ra, rb in zip(na, nb) for x, y in zip(ra, rb)), default=0.0)


def main() -> None:
    argv = sys.argv[1:]
    extra: list[str] = []
    if "--" in argv:
        extra = argv[argv.index("--") + 1:]
        argv = argv[: argv.index("--")]
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--a", required=True, help="nhnet-cli before")
    ap.add_argument("--b", required=True, help="nhnet-cli after")
    ap.add_argument("--worker", required=True, help="nhnet-bench-worker (PCL)")
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--tmp", default="/tmp/nhnet-ab", help="inputs and outputs")
    ap.add_argument("--b-args", default="",
                    help="arguments for B only, e.g. '--confidence' (A and B the same build)")
    ap.add_argument("clouds", nargs="+")
    args = ap.parse_args(argv)
    tmp = Path(args.tmp)
    tmp.mkdir(parents=True, exist_ok=True)
    rows = []
    for cloud in map(Path, args.clouds):
        xyz = xyz_of(cloud, tmp)
        times: dict[str, list[float]] = {k: [] for k in
                                         ("pcl", "pcl-call", "pcl-cpu", "A", "A-cpu", "B", "B-cpu")}
        loads = []
        pcl = [args.worker, "pcl-pca", "50", str(cloud), "--threads", str(args.threads)]
        outs = {}

        def pcl_run() -> None:
            loads.append(os.getloadavg()[0])
            wall, cpu, out = run(pcl)
            times["pcl"].append(wall)
            times["pcl-cpu"].append(cpu)
            times["pcl-call"].append(json.loads(out.strip().splitlines()[-1])["time_s"])
            print(f"{cloud.name} pcl {wall:.2f} s, CPU {cpu:.2f} s", flush=True)

        for _ in range(args.reps):
            for name, cli in (("A", args.a), ("B", args.b)):
                pcl_run()
                outs[name] = tmp / f"{xyz.stem}.{name}.xyzn"
                loads.append(os.getloadavg()[0])
                cmd = [cli, "estimate", str(xyz), str(outs[name]), "--threads", str(args.threads),
                       "--overwrite"]
                wall, cpu, _ = run(cmd + extra + (args.b_args.split() if name == "B" else []))
                times[name].append(wall)
                times[name + "-cpu"].append(cpu)
                print(f"{cloud.name} {name} {wall:.2f} s, CPU {cpu:.2f} s", flush=True)
        pcl_run()
        med = {k: statistics.median(v) for k, v in times.items()}
        diff = max_difference(outs["A"], outs["B"])
        rows.append((cloud.name, med, min(loads), max(loads), diff, len(times["A"])))
    print("\n| cloud | PCL k=50 process s (call s) [CPU s] | A s [CPU s] | A × PCL [CPU] "
          "| B s [CPU s] | B × PCL [CPU] | B / A [CPU] | load avg | max Δ normal |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, med, lo, hi, diff, n in rows:
        p, pc = med["pcl"], med["pcl-cpu"]
        print(f"| {name} | {p:.2f} ({med['pcl-call']:.2f}) [{pc:.2f}] "
              f"| {med['A']:.2f} [{med['A-cpu']:.2f}] | {med['A'] / p:.1f} [{med['A-cpu'] / pc:.1f}] "
              f"| {med['B']:.2f} [{med['B-cpu']:.2f}] | {med['B'] / p:.1f} [{med['B-cpu'] / pc:.1f}] "
              f"| {med['B'] / med['A']:.2f} [{med['B-cpu'] / med['A-cpu']:.2f}] "
              f"| {lo:.1f}-{hi:.1f} | {diff:.1e} |")
    print(f"\nmedians of {rows[0][5] if rows else 0} runs each; extra arguments: {' '.join(extra)}"
          f"{'; B also ' + args.b_args if args.b_args else ''}")


if __name__ == "__main__":
    main()
