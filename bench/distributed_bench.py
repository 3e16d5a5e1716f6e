#!/usr/bin/env python3
"""Benchmark of nhnet.distributed: one cloud, 1 and 2 Dask workers against one nhnet-cli process
and PCL `NormalEstimationOMP` (k=50), all timed in the same run.

    /usr/bin/python3 bench/distributed_bench.py [--points 20000000 | --cloud NAME.gt.xyzn]
        [--method mfps] [--tile-points 1000000] [--workers 1,2] [--orient WORDS] [--stream]
        [--out docs/benchmark/distributed]

The cloud: --points on a generated terrain (analytic normals), or --cloud, an nhnet-datagen
ground-truth file (e.g. bench/scaling.py's noisy fandisk); every run reads its points as binary PLY
(as XYZ text with --stream, the only format the stream reads).
For each worker count W it starts a `dask scheduler` and W `dask worker` processes (one thread
each, no nanny) on 127.0.0.1, runs `python3 -m nhnet.distributed estimate` against them and
reads every worker's peak resident memory (VmHWM) before stopping them; the references are one
`nhnet-cli estimate --threads W` process of the same file with the same --tile-points (with
--stream also `nhnet-cli estimate --stream`), and `nhnet-bench-worker pcl-pca 50 GT --threads W`
timed as a process (reading the ground-truth file and scoring included), as bench/scaling.py and
tools/ab_timing.py time PCL. Overhead = distributed wall time / nhnet-cli wall time - 1; × PCL =
wall time / PCL's process time; RMS / mean: angle errors of each output against the ground truth
(unoriented, nhnet.metrics). Writes table.md and results.json into --out
(after every configuration, so an interrupted run keeps what it measured), with the machine's
load average (/proc/loadavg, 1 min) sampled during every timed run: this project's machine is
shared, and the load says how much of it the run had. --orient: every run's orientation.
Needs PYTHONPATH=build/python (the bindings), build/cli/nhnet-cli and
build/bench/nhnet-bench-worker (NHNET_BUILD_DIR).
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


def cloud(n, path, gt):
    """n points on a wavy 2.5D terrain with boxes on it (smooth parts and sharp edges), noise
    0.1 % of the extent, written as binary PLY (float coordinates): `path` the points, `gt` with
    the surface's normals (the boxes lift whole cells, so every point's normal is the wave's);
    returns the normals."""
    import nhnet
    rng = np.random.default_rng(1)
    side = np.sqrt(n) * 0.01
    x, y = rng.random(n) * side, rng.random(n) * side
    z = 0.3 * np.sin(x / 3) * np.cos(y / 4) + np.where((np.floor(x) + np.floor(y)) % 7 == 0,
                                                       0.5, 0.0)
    normals = np.stack([-0.1 * np.cos(x / 3) * np.cos(y / 4), 0.075 * np.sin(x / 3) *
                        np.sin(y / 4), np.ones(n)], axis=1)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    pts = np.stack([x, y, z], axis=1) + rng.normal(0, 0.001 * side / 10, (n, 3))
    pts = pts.astype(np.float32).astype(np.float64)
    nhnet.write(str(path), pts)
    nhnet.write(str(gt), pts, normals)
    return normals


def score(out, gt_normals):
    """Angle errors of an output's normals against the ground truth (nhnet.metrics)."""
    import nhnet
    m = nhnet.metrics(nhnet.read(str(out)).normals, gt_normals)
    return {"rms_deg": m["rms"], "mean_deg": m["mean"]}


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


def nhnet_cli(inp, out, w, args, *extra):
    """One nhnet-cli estimate process as the distributed run is asked: wall s, peak MiB, load."""
    LOADS.clear()
    wall, mb, _ = timed([str(BUILD / "cli" / "nhnet-cli"), "estimate", str(inp), str(out),
                         "--method", args.method, "--threads", str(w), "--tile-points",
                         str(args.tile_points), "--orient", *args.orient.split(), *extra, "-q",
                         "--overwrite"])
    return wall, mb, load_range()


def pcl(gt, w):
    """PCL NormalEstimationOMP (k=50) over the ground-truth file, timed as a process."""
    LOADS.clear()
    wall, _, _ = timed([str(BUILD / "bench" / "nhnet-bench-worker"), "pcl-pca", "50", str(gt),
                        "--threads", str(w)])
    return wall, load_range()


def load_range():
    return [min(LOADS), sum(LOADS) / len(LOADS), max(LOADS)] if LOADS else [0.0, 0.0, 0.0]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=20_000_000)
    ap.add_argument("--cloud", help="an nhnet-datagen .gt.xyzn instead of the generated terrain")
    ap.add_argument("--method", default="mfps", choices=["pca", "mfps", "nhnet"])
    ap.add_argument("--tile-points", type=int, default=1_000_000)
    ap.add_argument("--workers", default="1,2")
    ap.add_argument("--orient", default="auto",
                    help="nhnet-cli's --orient words for every run (default auto: the MST here)")
    ap.add_argument("--stream", action="store_true", help="also time nhnet-cli --stream")
    ap.add_argument("--out", default=str(REPO / "docs" / "benchmark" / "distributed"))
    args = ap.parse_args()
    import nhnet
    rows = []
    with tempfile.TemporaryDirectory(prefix="nhnet-dask-bench-") as tmp:
        # --stream reads XYZ text only: then every run reads the same text file.
        inp = Path(tmp) / ("cloud.xyz" if args.stream else "cloud.ply")
        if args.cloud:  # its points for the runs, its normals for the scores: one read
            gt = Path(args.cloud)
            given = nhnet.read(str(gt))
            nhnet.write(str(inp), given.points)
            args.points, truth = len(given.points), given.normals
        else:
            gt = Path(tmp) / "cloud.gt.ply"
            truth = cloud(args.points, inp, gt)
        for w in [int(x) for x in args.workers.split(",")]:
            row = {"workers": w}
            row["pcl_s"], row["pcl_load"] = pcl(gt, w)
            ref = Path(tmp) / "ref.ply"
            row["cli_s"], row["cli_peak_mb"], row["cli_load"] = nhnet_cli(inp, ref, w, args)
            row["cli_score"] = score(ref, truth)
            if args.stream:
                row["stream_s"], row["stream_peak_mb"], row["stream_load"] = nhnet_cli(
                    inp, ref, w, args, "--stream")
                row["stream_score"] = score(ref, truth)
            LOADS.clear()
            out = Path(tmp) / "out.ply"
            row.update(distributed(w, inp, out, args, tmp))
            row["score"] = score(out, truth)
            row.update({"points_per_s": args.points / row["wall_s"],
                        "overhead": row["wall_s"] / row["cli_s"] - 1, "load": load_range()})
            rows.append(row)
            print(json.dumps(rows[-1]), flush=True)
            write_table(args, rows)


def write_table(args, rows):
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(json.dumps(rows, indent=1) + "\n")
    commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    source = f"--cloud {Path(args.cloud).name}" if args.cloud else f"--points {args.points}"
    lines = [f"# nhnet.distributed: {args.points:,} points"
             f"{' of ' + Path(args.cloud).name if args.cloud else ''}, --method {args.method}, "
             f"--tile-points {args.tile_points:,}", "",
             f"Machine: {platform.node()}, {os.cpu_count()} cores; "
             f"{datetime.datetime.utcnow():%Y-%m-%d %H:%M} UTC; commit {commit}.",
             f"Command: `/usr/bin/python3 bench/distributed_bench.py {source} "
             f"--method {args.method} --tile-points {args.tile_points} --workers {args.workers} "
             f"--orient '{args.orient}'{' --stream' if args.stream else ''}`",
             "", "Seconds of the whole process, × PCL k=50 (its process, same run), RMS / mean "
             "angle error in degrees, peak MiB; load average (1 min) min/mean/max during the run.",
             "", "| workers | run | s | × PCL | RMS / mean | peak MiB | load avg |",
             "|---|---|---|---|---|---|---|"]

    def load(v):
        return "/".join(f"{x:.1f}" for x in v)

    def err(sc):
        return f"{sc['rms_deg']:.2f} / {sc['mean_deg']:.2f}"
    for r in rows:
        p = r["pcl_s"]
        lines.append(f"| {r['workers']} | PCL NormalEstimationOMP k=50 | {p:.1f} | 1.0 | | | "
                     f"{load(r['pcl_load'])} |")
        lines.append(f"| {r['workers']} | nhnet-cli --threads W | {r['cli_s']:.1f} | "
                     f"{r['cli_s'] / p:.1f} | {err(r['cli_score'])} | {r['cli_peak_mb']:.0f} | "
                     f"{load(r['cli_load'])} |")
        if "stream_s" in r:
            lines.append(f"| {r['workers']} | nhnet-cli --stream --threads W | "
                         f"{r['stream_s']:.1f} | {r['stream_s'] / p:.1f} | "
                         f"{err(r['stream_score'])} | {r['stream_peak_mb']:.0f} | "
                         f"{load(r['stream_load'])} |")
        lines.append(f"| {r['workers']} | nhnet.distributed ({r['points_per_s']:,.0f} points/s, "
                     f"overhead {100 * r['overhead']:+.0f} % over nhnet-cli; client "
                     f"{r['client_peak_mb']:.0f} MiB) | {r['wall_s']:.1f} | "
                     f"{r['wall_s'] / p:.1f} | {err(r['score'])} | "
                     f"{', '.join(f'{m:.0f}' for m in r['worker_peak_mb'])} per worker | "
                     f"{load(r['load'])} |")
    lines += ["", "Task seconds of the distributed run per kind of task, summed over the workers:", ""]
    for r in rows:
        lines.append(f"- {r['workers']} worker(s): " + ", ".join(
            f"{k} {v:.1f}" for k, v in r["stages"].items() if v >= 0.05))
    (out / "table.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
