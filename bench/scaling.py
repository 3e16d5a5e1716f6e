"""Scaling benchmark (issue 10): time and peak memory per point from 100k to 10M points.

    /usr/bin/python3 bench/nhnet_bench.py --scaling [--sizes 100000,1000000,10000000]
        [--model fandisk] [--threads 2]
        [--methods pcl-pca,pca-auto,mfps-auto,mfps-stream,nhnet,mfps-whole,nhnet-whole]
        [--out docs/benchmark/scaling] [--data DIR] [--timeout S] [--max-rss-gb G]
        [--noise 0,0.1,0.6]

One dense cloud per size, sampled uniformly from one benchmark mesh (nhnet-datagen's sampler).
The Gaussian noise is 0.1 % of the bounding-box diagonal at 100k points and shrinks as
1/sqrt(N), i.e. it stays the same fraction of the point spacing: the automatic neighbourhood
sizes then stay the same and time per point measures the implementation, not a noise level that
grows with density (a fixed 0.1 % at 1M points makes the auto scales 137/274/300 instead of
43/86/129). `--noise` instead gives fixed levels (% of the diagonal), each a cloud at every size:
time per point across noise levels, the other half of issue 23's flatness target. Every method
runs in its own process (nhnet-bench-worker), so the peak RSS is its own; PCL
NormalEstimationOMP (k=50) runs before every other method and once at the end, and each method's
ratio is to the mean of the two PCL runs around it, taken seconds apart on the same cloud (the
machine may be shared). Per-stage seconds come from the core's progress stages.
`mfps-stream` is the out-of-core path, `nhnet-cli estimate --stream` on the cloud's text file:
its time is the whole command (it reads the file in passes and writes the result), its peak
is the process's, and its normals are scored against the cloud's ground truth like the others.
`nhnet-whole` and `mfps-whole` are what a user runs (issue 23's speed targets): the whole
`nhnet-cli estimate NAME.xyz OUT.xyzn` process on the bare coordinates, orientation `auto` (the
MST), timed from its start to its exit against PCL's whole worker process (read, estimate, score).
A method is skipped at a size where its own peak bytes per point at the size before predict more
than --max-rss-gb, so the streamed run goes on past the in-memory ones.

Writes OUT/table.md, OUT/results.json and OUT/scaling.png (time per point and peak bytes per
point against N, log x).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tools"))
from ab_timing import xyz_of  # noqa: E402  (the bare coordinates, written once per cloud)

BASE_POINTS = 100_000
BASE_NOISE_PERCENT = 0.1
PCL_K = 50
LABELS = {
    "pcl-pca": "PCL NormalEstimationOMP (k=50)",
    "pca-auto": "nhnet pca (auto k)",
    "mfps-auto": "nhnet mfps (auto scales)",
    "mfps-stream": "nhnet-cli estimate --method mfps --stream (whole command, text in/out)",
    "nhnet": "nhnet NH-Net (MFPS + network)",
    "mfps-whole": "nhnet-cli estimate --method mfps (whole command: read, estimate, MST, write)",
    "nhnet-whole": "nhnet-cli estimate, the default (whole command: read, estimate, MST, write)",
}
DESCRIPTOR_STAGES = ("bilateral filter", "canonical frames", "height maps")
NETWORK_STAGES = ("nhnet",)
STREAM_METHODS = {"mfps-stream": "mfps"}  # scaling method -> nhnet-cli --method, run --stream
# scaling method -> nhnet-cli estimate's arguments, run as a user does: on the bare coordinates
# (NAME.xyz), orientation `auto` (the MST for a bare cloud), one process from read to write
WHOLE_METHODS = {"mfps-whole": ["--method", "mfps"], "nhnet-whole": []}


def noise_percent(n: int, level: float | None = None) -> float:
    """The cloud's noise: `level` when given (--noise), else the constant-fraction rule."""
    return level if level is not None else BASE_NOISE_PERCENT * math.sqrt(BASE_POINTS / n)


# ensure_cloud's child: samples the mesh, adds the noise, writes MODEL_N.gt.xyzn.
_SAMPLE_CODE = """
import sys
from pathlib import Path
from nhnet_training import datagen
gt, model, n, noise = Path(sys.argv[1]), sys.argv[2], int(sys.argv[3]), float(sys.argv[4])
clean, normals, _, seed = datagen.sample_clean(model, "uniform", n)
noisy, _ = datagen.add_noise(clean, noise, seed + 1)
datagen.write_cloud(gt.parent / gt.name[: -len(".gt.xyzn")], noisy, normals, clean,
                    files=("gt.xyzn",))
"""


def ensure_cloud(datagen, data: Path, model: str, n: int, log, level: float | None = None) -> Path:
    """The cloud of n points (data/MODEL_N.gt.xyzn; with a fixed noise level
    MODEL_N_noiseL.gt.xyzn), sampled when missing in a process of its own: a child reports a
    peak RSS (ru_maxrss) of at least its parent's peak, so a 10M-point cloud sampled in this
    process (5 GB) became every method's peak at every later size."""
    suffix = "" if level is None else f"_noise{level:g}"
    gt = data / f"{model}_{n}{suffix}.gt.xyzn"
    if gt.exists():
        return gt
    log(f"data: sampling {n} points from {model} (noise {noise_percent(n, level):.4f} % of the "
        "diagonal)")
    gt.parent.mkdir(parents=True, exist_ok=True)
    package_dir = str(Path(datagen.__file__).resolve().parents[1])  # holds nhnet_training
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package_dir, env.get("PYTHONPATH")) if p)
    done = subprocess.run([sys.executable, "-c", _SAMPLE_CODE, str(gt), model, str(n),
                           repr(noise_percent(n, level))], env=env)
    if done.returncode != 0 or not gt.exists():
        raise RuntimeError(f"sampling {gt} failed (exit code {done.returncode})")
    return gt


def run_json(bench, method: str, cmd: list[str], timeout: float) -> tuple[dict, dict | None]:
    """Runs one method's child; returns its record (wall, peak; `error` when it failed) and the
    JSON object it printed last (None when it failed)."""
    r = bench.run_child(cmd, timeout)
    rec = {"method": method, "child_wall_s": r["wall_s"], "peak_mb": r["maxrss_mb"]}
    res = bench.last_json(r["stdout"]) if r["rc"] == 0 else None
    if res is None:
        why = "timeout" if r["timed_out"] else f"exit {r['rc']}"
        rec["error"] = f"{why}: {r['stderr'].strip()[-300:]}"
    return rec, res


def run_method(bench, worker: Path, method: str, gt: Path, threads: int, timeout: float) -> dict:
    rec, res = run_json(bench, method, [str(worker), method, str(PCL_K), str(gt), "--threads",
                                        str(threads)], timeout)
    if res is None:
        return rec
    for key in ("time_s", "rss_before_mb", "mean_deg", "rms_deg", "k_used", "scales_used",
                "stages", "points"):
        if key in res:
            rec[key] = res[key]
    return rec


def run_cli(bench, cli: Path, method: str, cmd: list[str], gt: Path, out: Path, timeout: float,
            time_of) -> dict:
    """One whole `nhnet-cli estimate` (cmd, writing `out`), then `nhnet-cli eval` of `out` against
    the cloud's normals (the ground truth). Nothing was resident before the process: its peak is
    its own; time_of(record, summary) is the run's seconds."""
    rec, res = run_json(bench, method, cmd, timeout)
    if res is None:
        out.unlink(missing_ok=True)
        return rec
    rec.update(time_s=time_of(rec, res), rss_before_mb=0.0, k_used=res["k"],
               scales_used=res["scales"], points=res["points"])
    if "tiles" in res:
        rec["tiles"] = res["tiles"]
    ev, score = run_json(bench, method, [str(cli), "eval", str(out), str(gt), "--json"], timeout)
    if score is None:
        rec["error"] = "eval " + ev["error"]
    else:
        rec.update(mean_deg=score["mean_deg"], rms_deg=score["rms_deg"])
    out.unlink(missing_ok=True)
    return rec


def run_stream(bench, cli: Path, method: str, gt: Path, threads: int, timeout: float,
               work: Path) -> dict:
    """`nhnet-cli estimate --stream` on the cloud's text file, timed by its own summary."""
    out, tiles = work / f"{gt.name}.{method}.xyzn", work / "stream-tiles"
    tiles.mkdir(parents=True, exist_ok=True)
    cmd = [str(cli), "estimate", str(gt), str(out), "--method", STREAM_METHODS[method], "--stream",
           "--temp-dir", str(tiles), "--threads", str(threads), "--orient", "none", "--quiet",
           "--json", "--overwrite"]
    return run_cli(bench, cli, method, cmd, gt, out, timeout, lambda rec, res: res["seconds"])


def run_whole(bench, cli: Path, method: str, gt: Path, threads: int, timeout: float,
              work: Path) -> dict:
    """The whole `nhnet-cli estimate NAME.xyz OUT` process, timed from its start to its exit."""
    xyz, out = xyz_of(gt, gt.parent), work / f"{gt.name}.{method}.xyzn"
    cmd = [str(cli), "estimate", str(xyz), str(out), "--threads", str(threads), "--quiet",
           "--json", "--overwrite"] + WHOLE_METHODS[method]
    return run_cli(bench, cli, method, cmd, gt, out, timeout,
                   lambda rec, res: rec["child_wall_s"])


def derive(rec: dict, n: int, threads: int, pcl_before: dict | None, pcl_after: dict | None) -> None:
    """Adds per-point figures and the ratio to the PCL runs around the record."""
    if "error" in rec:
        return
    rec["us_per_point"] = 1e6 * rec["time_s"] / n
    rec["points_per_s_per_core"] = n / (rec["time_s"] * threads)
    rec["peak_bytes_per_point"] = rec["peak_mb"] * 1048576 / n
    rec["delta_bytes_per_point"] = (rec["peak_mb"] - rec["rss_before_mb"]) * 1048576 / n
    # A whole command is compared with PCL's whole process (reading and scoring the cloud
    # included), the other methods with PCL's estimator call.
    key = "child_wall_s" if rec["method"] in WHOLE_METHODS else "time_s"
    refs = [p[key] for p in (pcl_before, pcl_after) if p and "error" not in p]
    if refs and rec["method"] != "pcl-pca":
        rec["ratio_to_pcl"] = rec["time_s"] / (sum(refs) / len(refs))
    st = rec.get("stages") or {}
    d = sum(st.get(s, 0.0) for s in DESCRIPTOR_STAGES)
    w = sum(st.get(s, 0.0) for s in NETWORK_STAGES)
    if d > 0:
        rec["descriptor_points_per_s"] = n / d
    if w > 0:
        rec["network_points_per_s"] = n / w


def fmt(v, spec=".2f") -> str:
    return "—" if v is None else format(v, spec)


def series_name(m: str, level) -> str:
    """A method's label, with the cloud's fixed noise level when there is one."""
    return LABELS.get(m, m) + ("" if level is None else f", {level:g} %")


def per_point(records: list[dict], n: int, m: str, level) -> float | None:
    """Mean µs per point of method m's runs on the cloud (n, level); None when none ran."""
    ok = [r["us_per_point"] for r in records
          if r["n"] == n and r["method"] == m and r.get("noise") == level and "error" not in r]
    return sum(ok) / len(ok) if ok else None


def noise_table(records: list[dict], methods: list[str], sizes: list[int], levels: list) -> list[str]:
    """Time per point across the noise levels at each size, relative to the first level."""
    md = ["", "## Time per point relative to the first noise level (flat = 1.00; bar: within "
          "±25 %)", "", "| method | points | " + " | ".join(f"{v:g} %" for v in levels) + " |",
          "|---|---|" + "---|" * len(levels)]
    for m in methods:
        for n in sizes:
            row = [per_point(records, n, m, v) for v in levels]
            if row[0] is not None and any(x is not None for x in row[1:]):
                md.append(f"| {LABELS.get(m, m)} | {n} | "
                          + " | ".join(fmt(x / row[0]) if x is not None else "—" for x in row) + " |")
    return md


def sweep_table(records: list[dict], methods: list[str], sizes: list[int], levels: list) -> list[str]:
    """Issue 56's sweep: at each size and noise level, every method's time as a ratio to PCL
    k=50 (the runs around it) with its RMS / mean error beside it, and the time per point
    relative to the level with the lowest (flat: the largest over the smallest within 1.3)."""
    md = ["", "## Across noise levels: × PCL, RMS / mean error (°)", "",
          "| points | method | " + " | ".join(f"{v:g} %" for v in levels) + " | slowest / "
          "fastest per point |", "|---|---|" + "---|" * (len(levels) + 1)]
    for n in sizes:
        for m in methods:
            cells, per = [], []
            for v in levels:
                r = next((r for r in records if r["n"] == n and r["method"] == m
                          and r.get("noise") == v and "error" not in r), None)
                if r is None:
                    cells.append("—")
                    continue
                ratio = "" if r.get("ratio_to_pcl") is None else f"{r['ratio_to_pcl']:.2f}×, "
                cells.append(f"{ratio}{fmt(r.get('rms_deg'))} / {fmt(r.get('mean_deg'))}")
                per.append(r["us_per_point"])
            if len(per) > 1:
                md.append(f"| {n} | {LABELS.get(m, m)} | " + " | ".join(cells)
                          + f" | {max(per) / min(per):.2f} |")
    return md


def report(records: list[dict], meta: dict, methods: list[str]) -> list[str]:
    sizes = sorted({r["n"] for r in records})
    levels = meta.get("noise") or [None]
    cloud = (f"noise {', '.join(f'{v:g}' for v in levels)} % of the diagonal at every size"
             if meta.get("noise") else
             f"noise {BASE_NOISE_PERCENT} % of the diagonal at {BASE_POINTS} points, scaled by "
             f"sqrt({BASE_POINTS}/N) (constant fraction of the spacing)")
    md = ["# nhnet scaling benchmark", "",
          f"- date: {meta['date']}", f"- machine: {meta['machine']}",
          f"- command: `{meta['command']}`", f"- commit: {meta['commit']}",
          f"- cloud: {meta['model']} sampled uniformly, {cloud}",
          f"- threads per method: {meta['threads']}; ratio = time / mean of the PCL k={PCL_K} "
          "runs just before and after, same cloud", ""]
    if meta.get("skipped"):
        md += [f"- not run: {s}" for s in meta["skipped"]] + [""]
    md += ["| points | method | time s | µs/point | × PCL | points/s/core | peak MB | "
           "peak B/point | Δ B/point | k / scales | mean ° | RMS ° |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for n, level in [(n, v) for n in sizes for v in levels]:
        label = str(n) if level is None else f"{n}, {level:g} %"
        for m in methods:
            for r in [r for r in records if r["n"] == n and r["method"] == m
                      and r.get("noise") == level]:
                if "error" in r:
                    md.append(f"| {label} | {LABELS.get(m, m)} | error: {r['error'][:80]} |"
                              + " |" * 9)
                    continue
                ks = str(r.get("k_used", "")) + (
                    " / " + ",".join(map(str, r["scales_used"])) if r.get("scales_used") else "")
                md.append(f"| {label} | {LABELS.get(m, m)} | {fmt(r['time_s'])} | "
                          f"{fmt(r['us_per_point'], '.1f')} | {fmt(r.get('ratio_to_pcl'))} | "
                          f"{fmt(r['points_per_s_per_core'], '.0f')} | {fmt(r['peak_mb'], '.0f')} | "
                          f"{fmt(r['peak_bytes_per_point'], '.0f')} | "
                          f"{fmt(r['delta_bytes_per_point'], '.0f')} | {ks} | "
                          f"{fmt(r.get('mean_deg'))} | {fmt(r.get('rms_deg'))} |")
    md += ["", "## Time per point relative to the smallest size (flat = 1.00; bar: within ±25 %)",
           "", "| method | " + " | ".join(str(n) for n in sizes) + " |",
           "|---|" + "---|" * len(sizes)]
    for m, level in [(m, v) for m in methods for v in levels]:
        row = {n: per_point(records, n, m, level) for n in sizes}
        row = {n: x for n, x in row.items() if x is not None}
        if row:
            base = row[min(row)]
            md.append(f"| {series_name(m, level)} | "
                      + " | ".join(fmt(row[n] / base) if n in row else "—" for n in sizes) + " |")
    if len(levels) > 1:
        md += sweep_table(records, methods, sizes, levels)
        md += noise_table(records, methods, sizes, levels)
    md += ["", "## Seconds per stage (core progress stages)", ""]
    for r in records:
        if r.get("stages") and r["method"] != "pcl-pca":
            st = ", ".join(f"{k} {v:.2f}" for k, v in sorted(r["stages"].items(),
                                                            key=lambda kv: -kv[1]) if v >= 0.005)
            extra = ""
            if r.get("descriptor_points_per_s"):
                extra = (f"; descriptors {r['descriptor_points_per_s']:.0f} points/s, network "
                         f"{r.get('network_points_per_s', float('nan')):.0f} points/s")
            level = "" if r.get("noise") is None else f" {r['noise']:g} %"
            md.append(f"- {r['n']}{level} {r['method']}: {st}{extra}")
    return md


def write_plot(records: list[dict], methods: list[str], path: Path, title: str) -> str | None:
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:
        return f"no plot: matplotlib not importable ({e})"
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    levels = sorted({r.get("noise") for r in records}, key=lambda v: -1 if v is None else v)
    for m, level in [(m, v) for m in methods for v in levels]:
        ok = sorted((r for r in records if r["method"] == m and r.get("noise") == level
                     and "error" not in r), key=lambda r: r["n"])
        if not ok:
            continue
        xs, name = [r["n"] for r in ok], series_name(m, level)
        axes[0].plot(xs, [r["us_per_point"] for r in ok], "o-", label=name)
        axes[1].plot(xs, [r["peak_bytes_per_point"] for r in ok], "o-", label=name)
    axes[0].set_ylabel("µs per point (wall)")
    axes[1].set_ylabel("peak RSS bytes per point")
    axes[1].axhline(400, color="k", lw=0.8, ls="--", label="budget 400 B/point")
    for ax in axes:
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("points")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return None


def run_cloud(bench, a, cloud: tuple, todo: list[str], with_pcl: bool, paths: tuple,
              log) -> list[dict]:
    """Every method of `todo` on the cloud (n points, noise level or None), each between two PCL
    runs."""
    (n, level), (worker, cli, data, out) = cloud, paths
    gt = ensure_cloud(bench.datagen, data, a.model, n, log, level)
    order = []
    for m in todo:
        order += (["pcl-pca"] if with_pcl else []) + [m]
    order += ["pcl-pca"] if with_pcl else []
    runs = []
    for m in order:
        if m in STREAM_METHODS:
            rec = run_stream(bench, cli, m, gt, a.threads, a.timeout, out)
        elif m in WHOLE_METHODS:
            rec = run_whole(bench, cli, m, gt, a.threads, a.timeout, out)
        else:
            rec = run_method(bench, worker, m, gt, a.threads, a.timeout)
        rec["n"], rec["noise"] = n, level
        runs.append(rec)
        log(f"{n} {'' if level is None else f'{level:g} % '}{m}: " + (
            rec["error"] if "error" in rec else f"{rec['time_s']:.2f} s, peak {rec['peak_mb']:.0f} MB"))
    for i, rec in enumerate(runs):
        before = runs[i - 1] if i > 0 and runs[i - 1]["method"] == "pcl-pca" else None
        after = runs[i + 1] if i + 1 < len(runs) and runs[i + 1]["method"] == "pcl-pca" else None
        derive(rec, n, a.threads, before, after)
    return runs


def main(argv: list[str], bench) -> int:
    """Entry point; `bench` is the nhnet_bench module (children, machine info, datagen)."""
    ap = argparse.ArgumentParser(prog="nhnet_bench.py --scaling", description=__doc__.split("\n\n")[0])
    ap.add_argument("--scaling", action="store_true")
    ap.add_argument("--sizes", default="100000,1000000,10000000",
                    help="comma-separated point counts (default 100k, 1M, 10M)")
    ap.add_argument("--model", default="fandisk", help="benchmark mesh to sample (default fandisk)")
    ap.add_argument("--methods", default=",".join(LABELS),
                    help="comma-separated worker methods (default " + ",".join(LABELS) + ")")
    ap.add_argument("--threads", type=int, default=2, help="threads of each method (default 2)")
    ap.add_argument("--nhnet-max-points", type=int, default=1_000_000,
                    help="run nhnet only on sizes up to this (default 1M; its network runs at "
                         "about 7k points/s on 2 CPU cores)")
    ap.add_argument("--data", default=None,
                    help="cloud directory (default data/generated/scaling)")
    ap.add_argument("--out", default=None, help="results directory (default build/bench-scaling)")
    ap.add_argument("--build", default=str(bench.REPO / "build"))
    ap.add_argument("--timeout", type=float, default=3600.0,
                    help="seconds one method may take on one cloud (default 3600)")
    ap.add_argument("--max-rss-gb", type=float, default=None,
                    help="skip a size whose estimated MFPS peak (from the previous size's bytes "
                         "per point) exceeds this many GiB (default: 70 %% of MemTotal)")
    ap.add_argument("--noise", default=None,
                    help="comma-separated fixed noise levels in %% of the diagonal, each a cloud "
                         "at every size (default: 0.1 %% at 100k points, scaled to keep the same "
                         "fraction of the spacing)")
    a = ap.parse_args(argv)
    log = lambda msg: print(msg, flush=True)  # noqa: E731
    sizes = [int(x) for x in a.sizes.split(",")]
    methods = a.methods.split(",")
    bad = [m for m in methods if m not in LABELS]
    if bad:
        ap.error(f"unknown methods {bad}; known: {','.join(LABELS)}")
    worker = Path(a.build) / "bench" / "nhnet-bench-worker"
    cli = Path(a.build) / "cli" / "nhnet-cli"
    for exe in (worker, cli):
        if not os.access(exe, os.X_OK):
            print(f"nhnet_bench: {exe} not built; run: bash scripts/build.sh", file=sys.stderr)
            return 2
    data = Path(a.data) if a.data else bench.REPO / "data" / "generated" / "scaling"
    out = Path(a.out) if a.out else bench.REPO / "build" / "bench-scaling"
    data.mkdir(parents=True, exist_ok=True)
    out.mkdir(parents=True, exist_ok=True)
    mem_total_gb = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    max_rss = a.max_rss_gb if a.max_rss_gb is not None else 0.7 * mem_total_gb
    meta = {"date": dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "machine": bench.machine_info(), "commit": bench.git_commit(),
            "command": "/usr/bin/python3 bench/nhnet_bench.py " + " ".join(argv),
            "model": a.model, "threads": a.threads, "skipped": [],
            "noise": [float(v) for v in a.noise.split(",")] if a.noise else None}
    records: list[dict] = []
    t0 = time.perf_counter()
    last_bpp: dict[str, float] = {}  # peak bytes/point of each method at the previous size
    for n in sizes:
        # Each method's peak at this size is predicted from its own peak bytes per point at the
        # previous size (nhnet's fixed libtorch overhead at a small size says nothing about 10M);
        # a method that would not fit is skipped here, the others (--stream) still run.
        def fits(m: str) -> bool:
            if last_bpp.get(m, 0.0) * n / 2**30 <= max_rss:
                return True
            why = (f"{m} at {n} points: its peak of {last_bpp[m]:.0f} bytes/point at the size "
                   f"before predicts {last_bpp[m] * n / 2**30:.1f} GiB > {max_rss:.1f} GiB allowed")
            meta["skipped"].append(why)
            log("skip " + why)
            return False

        todo = []
        for m in methods:
            if m == "nhnet" and n > a.nhnet_max_points:
                meta["skipped"].append(f"nhnet at {n} points (--nhnet-max-points "
                                       f"{a.nhnet_max_points})")
            elif m != "pcl-pca" and fits(m):
                todo.append(m)
        if not todo:
            continue
        with_pcl = fits("pcl-pca")  # the reference of every ratio, run whether listed or not
        runs = []
        for level in meta["noise"] or [None]:
            runs += run_cloud(bench, a, (n, level), todo, with_pcl, (worker, cli, data, out), log)
        here: dict[str, float] = {}  # a method skipped at this size keeps its older figure
        for rec in runs:
            if "error" not in rec:
                here[rec["method"]] = max(here.get(rec["method"], 0.0), rec["peak_bytes_per_point"])
        last_bpp.update(here)
        records += runs
    meta["wall_s"] = time.perf_counter() - t0
    md = report(records, meta, methods)
    (out / "table.md").write_text("\n".join(md) + "\n")
    (out / "results.json").write_text(json.dumps({"meta": meta, "records": records}, indent=1) + "\n")
    note = write_plot(records, methods, out / "scaling.png",
                      f"nhnet scaling, {a.model}, {a.threads} threads, {meta['date']}")
    print("\n".join(md))
    log(note or f"wrote {out / 'table.md'}, {out / 'results.json'}, {out / 'scaling.png'}")
    return 0 if records and all("error" not in r for r in records) else 1
