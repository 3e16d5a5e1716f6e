#!/usr/bin/env python3
"""Benchmark of nhnet.distributed: one cloud, 1 and 2 Dask workers against one nhnet-cli process.

    /usr/bin/python3 bench/distributed_bench.py [--points 20000000] [--method mfps]
        [--tile-points 1000000] [--workers 1,2] [--orient WORDS] [--out docs/benchmark/distributed]

For each worker count W it starts a `dask scheduler` and W `dask worker` processes (one thread
each, no nanny) on 127.0.0.1, runs `python3 -m nhnet.distributed estimate` against them and
reads every worker's peak resident memory (VmHWM) before stopping them; the reference is one
`nhnet-cli estimate --threads W` process of the same file with the same --tile-points. Overhead =
distributed wall time / nhnet-cli wall time - 1. Writes table.md and results.json into --out
(after every configuration, so an interrupted run keeps what it measured), with the machine's
load average (/proc/loadavg, 1 min) sampled during every timed run: this project's machine is
shared, and the load says how much of it the run had. --orient: both runs' orientation.
Needs PYTHONPATH=build/python (the bindings) and build/cli/nhnet-cli (NHNET_BUILD_DIR).
"""

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
BUILD = Path(os.environ.get("NHNET_BUILD_DIR", REPO / "build"))
ENV = dict(os.environ, OMP_NUM_THREADS="1")


def cloud(n, path):
    """n points on a wavy 2.5D terrain with boxes on it (smooth parts and sharp edges), noise
    0.1 % of the extent, written as binary PLY (float coordinates) in slices."""
    import nhnet
    rng = np.random.default_rng(1)
    side = np.sqrt(n) * 0.01
    x, y = rng.random(n) * side, rng.random(n) * side
    z = 0.3 * np.sin(x / 3) * np.cos(y / 4) + np.where((np.floor(x) + np.floor(y)) % 7 == 0,
                                                       0.5, 0.0)
    pts = np.stack([x, y, z], axis=1) + rng.normal(0, 0.001 * side / 10, (n, 3))
    nhnet.write(str(path), pts.astype(np.float32).astype(np.float64))


def peak_kb(pid):
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1])
    return 0


LOADS = []  # 1-minute load averages sampled during the current timed run


def timed(cmd):
    """Wall seconds and peak RSS (MiB) of a command, polling /proc."""
    t0 = time.time()
    p = subprocess.Popen(cmd, env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    peak, tick = 0, 0
    while p.poll() is None:
        tick += 1
        if tick % 50 == 1:
            LOADS.append(float(Path("/proc/loadavg").read_text().split()[0]))
        try:
            peak = max(peak, peak_kb(p.pid))
        except (FileNotFoundError, ProcessLookupError):
            pass
        time.sleep(0.1)
    err = p.communicate()[1].decode()
    if p.returncode:
        sys.exit(f"{cmd[0]} failed ({p.returncode}):\n{err}")
    return time.time() - t0, peak / 1024, err


def distributed(workers, inp, out, args, tmp):
    sched_file = Path(tmp) / f"sched{workers}.json"
    procs = [subprocess.Popen(["dask", "scheduler", "--host", "127.0.0.1", "--port", "0",
                               "--no-dashboard", "--scheduler-file", str(sched_file)],
                              env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    while not sched_file.exists():
        time.sleep(0.2)
    address = json.loads(sched_file.read_text())["address"]
    ws = [subprocess.Popen(["dask", "worker", "--scheduler-file", str(sched_file),
                            "--nthreads", "1", "--no-nanny", "--no-dashboard", "--host",
                            "127.0.0.1", "--memory-limit", "0"],
                           env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
          for _ in range(workers)]
    from distributed import Client
    c = Client(address, timeout=60)
    c.wait_for_workers(workers, timeout=120)
    c.get_task_stream(start=time.time())  # the scheduler records tasks from now on
    t0 = time.time()
    try:
        wall, client_mb, err = timed([sys.executable, "-m", "nhnet.distributed", "estimate",
                                      str(inp), str(out), "--scheduler", address, "--quiet",
                                      "--method", args.method, "--tile-points",
                                      str(args.tile_points), "--orient", *args.orient.split()])
        worker_mb = [peak_kb(w.pid) / 1024 for w in ws]
        stages = task_seconds(c.get_task_stream(start=t0))
    finally:
        c.close()
        for p in ws + procs:
            p.terminate()
        for p in ws + procs:
            p.wait()
    return {"wall_s": wall, "client_peak_mb": client_mb, "worker_peak_mb": worker_mb,
            "stages": stages, "log": err.strip().splitlines()[-2:]}


def task_seconds(records):
    """Compute seconds summed over the workers per kind of task of the job: its task names are
    TOKEN-KIND[-N...] (nhnet-PID-NS-leak-0-3 -> leak), probe-rough apart from probe; Dask's
    own names FUNCTION-HASH (the job's unnamed tasks) -> FUNCTION."""
    out = {}
    for r in records:
        key = r["key"] if isinstance(r["key"], str) else str(r["key"])
        parts = key.split("-")[3:] if key.startswith("nhnet-") else key.split("-")[:1]
        kind = "-".join(x for x in parts if not x.isdigit()) or key
        s = sum(x["stop"] - x["start"] for x in r["startstops"] if x["action"] == "compute")
        out[kind] = out.get(kind, 0.0) + s
    return dict(sorted(out.items(), key=lambda kv: -kv[1]))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=20_000_000)
    ap.add_argument("--method", default="mfps", choices=["pca", "mfps"])
    ap.add_argument("--tile-points", type=int, default=1_000_000)
    ap.add_argument("--workers", default="1,2")
    ap.add_argument("--orient", default="auto",
                    help="nhnet-cli's --orient words for both runs (default auto: the MST here)")
    ap.add_argument("--out", default=str(REPO / "docs" / "benchmark" / "distributed"))
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="nhnet-dask-bench-") as tmp:
        inp = Path(tmp) / "cloud.ply"
        cloud(args.points, inp)
        for w in [int(x) for x in args.workers.split(",")]:
            LOADS.clear()
            cli_s, cli_mb, _ = timed([str(BUILD / "cli" / "nhnet-cli"), "estimate", str(inp),
                                      str(Path(tmp) / "ref.ply"), "--method", args.method,
                                      "--threads", str(w), "--tile-points",
                                      str(args.tile_points), "--orient", *args.orient.split(),
                                      "-q", "--overwrite"])
            cli_load = list(LOADS)
            LOADS.clear()
            d = distributed(w, inp, Path(tmp) / "out.ply", args, tmp)
            rows.append({"workers": w, "cli_s": cli_s, "cli_peak_mb": cli_mb, **d,
                         "points_per_s": args.points / d["wall_s"],
                         "overhead": d["wall_s"] / cli_s - 1,
                         "cli_load": [min(cli_load), sum(cli_load) / len(cli_load), max(cli_load)],
                         "load": [min(LOADS), sum(LOADS) / len(LOADS), max(LOADS)]})
            print(json.dumps(rows[-1]), flush=True)
            write_table(args, rows)


def write_table(args, rows):
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(json.dumps(rows, indent=1) + "\n")
    commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    lines = [f"# nhnet.distributed: {args.points:,} points, --method {args.method}, "
             f"--tile-points {args.tile_points:,}", "",
             f"Machine: {platform.node()}, {os.cpu_count()} cores; "
             f"{datetime.datetime.utcnow():%Y-%m-%d %H:%M} UTC; commit {commit}.",
             f"Command: `/usr/bin/python3 bench/distributed_bench.py --points {args.points} "
             f"--method {args.method} --tile-points {args.tile_points} --workers {args.workers} "
             f"--orient '{args.orient}'`",
             "", "| workers | nhnet.distributed s | points/s | peak MiB per worker | client peak "
             "MiB | nhnet-cli --threads W s | nhnet-cli peak MiB | overhead | load avg (min/mean/"
             "max) distributed; nhnet-cli |",
             "|---|---|---|---|---|---|---|---|---|"]
    def load(v):
        return "/".join(f"{x:.1f}" for x in v)
    for r in rows:
        lines.append(f"| {r['workers']} | {r['wall_s']:.1f} | {r['points_per_s']:,.0f} | "
                     f"{', '.join(f'{m:.0f}' for m in r['worker_peak_mb'])} | "
                     f"{r['client_peak_mb']:.0f} | {r['cli_s']:.1f} | {r['cli_peak_mb']:.0f} | "
                     f"{100 * r['overhead']:+.0f} % | {load(r['load'])}; {load(r['cli_load'])} |")
    lines += ["", "Task seconds of the distributed run per kind of task, summed over the workers:", ""]
    for r in rows:
        lines.append(f"- {r['workers']} worker(s): " + ", ".join(
            f"{k} {v:.1f}" for k, v in r["stages"].items() if v >= 0.05))
    (out / "table.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
