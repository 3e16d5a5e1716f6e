#!/usr/bin/env python3
"""nhnet benchmark: every normal estimator on the same generated clouds, in one run.

Protocol: docs/design/benchmark-protocol.md (paper Sec. 6.1). Data: nhnet-datagen (training/nhnet_training),
generated here when missing. For every cloud and every method one child process runs the
estimator (``nhnet-bench-worker`` for nhnet / PCL / CGAL, ``open3d_worker.py`` for Open3D), so the
peak RSS read with ``os.wait4`` is that method's own. Accuracy is scored with nhnet's metrics
(core/include/nhnet/eval/metrics.hpp: unoriented angle error; mean, RMS, PGP5, PGP10, share over
30 degrees).

    /usr/bin/python3 bench/nhnet_bench.py [--quick] [--points N] [--out DIR] [--data DIR]
        [--categories A,B] [--models M1,M2] [--levels 0.1,0.2] [--methods a,b] [--threads T]
        [--build DIR] [--open3d-python PY] [--timeout S]
    /usr/bin/python3 bench/nhnet_bench.py --scaling [--sizes 100000,1000000,10000000] ...
        (time and peak memory per point against the cloud size: bench/scaling.py)

Writes DIR/results.json (every per-cloud record), DIR/table.md (per category and overall,
plus every category per noise level) and DIR/chart.png (mean error per category, as the paper's
Fig. 5, and time ratio to PCL). See bench/README.md.
"""

from __future__ import annotations

import argparse
import hashlib
import datetime as dt
import json
import math
import os
import platform
import shlex
import subprocess
import sys
import tempfile
import time
from itertools import zip_longest
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "training"))

from nhnet_training import datagen  # noqa: E402

# Methods, in table order: id -> (label, needs K, runner). "worker" = nhnet-bench-worker.
METHODS: dict[str, tuple[str, bool, str]] = {
    "mfps-auto": ("nhnet mfps (auto scales)", False, "worker"),
    "mfps": ("nhnet mfps (paper scales)", True, "worker"),
    "nhnet": ("nhnet NH-Net (shipped model)", False, "worker"),
    "nhnet-mix": ("nhnet NH-Net without the learned fit", False, "worker"),
    "nhnet-bf16": ("nhnet NH-Net, network in bfloat16", False, "worker"),
    "pca-auto": ("nhnet pca (auto k)", False, "worker"),
    "pca": ("nhnet pca", True, "worker"),
    "pcl-pca": ("PCL NormalEstimationOMP", True, "worker"),
    "cgal-jet": ("CGAL jet_estimate_normals", True, "worker"),
    "cgal-vcm": ("CGAL vcm_estimate_normals", True, "worker"),
    "open3d": ("Open3D estimate_normals", True, "open3d"),
}
REFERENCE = "pcl-pca"  # time ratios are to this method on the same cloud at the same K

# K of the single-scale peers per category (docs/design/benchmark-protocol.md#data). The first K is the category's
# main one (time ratios of K-free methods, the overall table). MFPS "paper scales" are
# {K/2, K, 3K/2}: the paper's {50, 100, 150}, doubled on BigNoise; run where one K is given.
PROTOCOL_K: dict[str, list[int]] = {
    "SharpFeature": [100],
    "RichFeature": [100],
    "SmoothSurface": [100],
    "BigNoise": [200],
    "PCPNetNoise": [50, 18, 112],
    "PCPNetDensity": [50, 18, 112],
}
PAPER_CATEGORIES = ["SharpFeature", "RichFeature", "SmoothSurface", "BigNoise"]
QUICK_POINTS = 10000
FULL_POINTS = 20000  # paper: 10k-100k per cloud; --points for more
VCM_OFFSET_SPACINGS = 5.0  # CGAL VCM offset radius, in average spacings (docs/design/benchmark-protocol.md#peers-same-clouds-same-machine-same-run)


def paper_scales(k: int) -> list[int]:
    return [k // 2, k, k + k // 2]


# ----------------------------------------------------------------------------- data

def quick_selection() -> tuple[list[str], dict[str, list[float]]]:
    """Quick mode: the first model of each paper category at its middle noise level."""
    models, levels = [], {}
    for cat in PAPER_CATEGORIES:
        ms, lv = datagen.BENCHMARK_CATEGORIES[cat]
        models.append(ms[0])
        levels[cat] = [lv[len(lv) // 2]]
    return models, levels


def ensure_data(data: Path, points: int, categories: list[str], models: set[str] | None,
                log) -> list[dict]:
    """Benchmark clouds under data/benchmark, generated (deterministically) when missing."""
    index_path = data / "benchmark" / "index.json"
    want = {(c, m) for c in categories
            for m in (datagen.BENCHMARK_MODELS if c.startswith("PCPNet")
                      else datagen.BENCHMARK_CATEGORIES[c][0])
            if models is None or m in models}
    if index_path.exists():
        index = json.loads(index_path.read_text())
        have = {(c["category"], c["model"]) for c in index["clouds"]}
        if index.get("points_per_cloud") == points and want <= have:
            log(f"data: reusing {index_path}")
            return index["clouds"]
    log(f"data: generating {len(want)} (category, model) pairs x {points} points into {data}")
    index = datagen.generate(data, "benchmark", points, False, datagen.BASE_SEED,
                             set(categories), None, log=log, models=models)
    return index["clouds"]


# ----------------------------------------------------------------------------- children

def run_child(cmd: list[str], timeout: float, env: dict | None = None) -> dict:
    """Runs cmd in its own process; returns rc, stdout, stderr, wall and the child's peak RSS."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        p = subprocess.Popen(cmd, stdout=out, stderr=err, env=env)
        status, ru, timed_out = None, None, False
        while True:
            pid, status, ru = os.wait4(p.pid, os.WNOHANG)
            if pid:
                break
            if time.perf_counter() - t0 > timeout:
                p.kill()
                _, status, ru = os.wait4(p.pid, 0)
                timed_out = True
                break
            time.sleep(0.01)
        p.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
        wall = time.perf_counter() - t0
        out.seek(0)
        err.seek(0)
        return {"rc": p.returncode, "stdout": out.read().decode(errors="replace"),
                "stderr": err.read().decode(errors="replace"), "wall_s": wall,
                "maxrss_mb": ru.ru_maxrss / 1024.0, "timed_out": timed_out}


def last_json(text: str) -> dict | None:
    for line in reversed(text.strip().splitlines()):
        line = line.strip()
        if line.startswith("{"):
            try:
                return json.loads(line)
            except json.JSONDecodeError:
                return None
    return None


class Runner:
    def __init__(self, worker: Path, cli: Path, open3d_python: str | None, threads: int,
                 timeout: float, tmp: Path):
        self.worker, self.cli, self.py = worker, cli, open3d_python
        self.threads, self.timeout, self.tmp = threads, timeout, tmp

    def run(self, method: str, k: int, gt: Path, category: str) -> dict:
        rec: dict = {"method": method, "k": k}
        if METHODS[method][2] == "open3d":
            if not self.py:
                rec["error"] = "open3d not available"
                return rec
            est = self.tmp / "open3d_est.xyzn"
            env = dict(os.environ, OMP_NUM_THREADS=str(self.threads))
            r = run_child([self.py, str(REPO / "bench" / "open3d_worker.py"), str(gt), str(k),
                           str(est)], self.timeout, env)
            res = last_json(r["stdout"]) if r["rc"] == 0 else None
            if res is not None:
                ev = subprocess.run([str(self.cli), "eval", str(est), str(gt), "--json"],
                                    capture_output=True, text=True)
                score = last_json(ev.stdout) if ev.returncode == 0 else None
                if score is None:
                    res = None
                    r["stderr"] += ev.stderr
                else:
                    res.update(mean_deg=score["mean_deg"], rms_deg=score["rms_deg"],
                               pgp5=score["pgp5_pct"] / 100.0, pgp10=score["pgp10_pct"] / 100.0,
                               over30=score["over30_pct"] / 100.0, count=score["count"],
                               invalid=score["invalid"])
            est.unlink(missing_ok=True)
        else:
            cmd = [str(self.worker), method, str(k), str(gt), "--threads", str(self.threads)]
            if method == "mfps":
                cmd += ["--scales", ",".join(map(str, paper_scales(k)))]
            if method == "cgal-vcm":
                cmd += ["--vcm-offset", str(VCM_OFFSET_SPACINGS)]
            r = run_child(cmd, self.timeout)
            res = last_json(r["stdout"]) if r["rc"] == 0 else None
        rec.update(child_wall_s=r["wall_s"], peak_mb=r["maxrss_mb"])
        if res is None:
            why = "timeout" if r["timed_out"] else f"exit {r['rc']}"
            rec["error"] = f"{why}: {r['stderr'].strip()[-300:]}"
        else:
            rec.update({key: res[key] for key in ("time_s", "rss_before_mb", "mean_deg", "rms_deg",
                                                   "pgp5", "pgp10", "over30", "count",
                                                   "invalid")})
            for key in ("k_used", "scales_used"):
                if key in res:
                    rec[key] = res[key]
        return rec


def find_open3d_python(explicit: str | None, log) -> tuple[str | None, str]:
    cands = [explicit] if explicit else [str(REPO / "build" / "bench-venv" / "bin" / "python"),
                                         sys.executable]
    why = ""
    for py in cands:
        if not py or not Path(py).exists():
            why = why or f"{py} does not exist"
            continue
        r = subprocess.run([py, "-c", "import open3d; print(open3d.__version__)"],
                           capture_output=True, text=True)
        if r.returncode == 0:
            return py, r.stdout.strip().splitlines()[-1]
        why = (r.stderr.strip().splitlines() or ["import failed"])[-1]
    return None, why


# ----------------------------------------------------------------------------- tables

def run_ks(method: str, category: str, extra_k: list[int]) -> list[int]:
    """The K values a method runs at on a cloud of the category: [0] for K-free methods; the
    protocol's K, then --extra-k (a peer's K sweep, for its best K); mfps at one K only."""
    if not METHODS[method][1]:
        return [0]
    ks = PROTOCOL_K[category]
    if method == "mfps":
        return ks if len(ks) == 1 else []  # paper scales only where the protocol gives one K
    return ks + [k for k in extra_k if k not in ks]


def row_key(rec: dict, ks: set[int]) -> str:
    """Table row of a record: method id, plus k when the category ran at several K (ks)."""
    if METHODS[rec["method"]][1] and len(ks) > 1:
        return f"{rec['method']} k={rec['k']}"
    return rec["method"]


def category_ks(records: list[dict], category: str) -> set[int]:
    """Every K a K-dependent method ran at on the category's clouds."""
    return {r["k"] for r in records if r["category"] == category and METHODS[r["method"]][1]}


def aggregate(recs: list[dict], ref_time: dict) -> dict:
    """Mean over clouds of the per-cloud figures; time ratio = geometric mean of per-cloud ratios
    to PCL on the same cloud; peak memory = max over clouds."""
    ok = [r for r in recs if "error" not in r]
    out = {"clouds": len(recs), "ok": len(ok), "errors": len(recs) - len(ok)}
    if not ok:
        return out
    n = len(ok)
    for key in ("mean_deg", "rms_deg"):
        out[key] = sum(r[key] for r in ok) / n
    for key in ("pgp5", "pgp10"):
        out[key] = 100.0 * sum(r[key] for r in ok) / n
    # records of runs before the share over 30 degrees was measured have none: no figure then
    out["over30"] = (100.0 * sum(r["over30"] for r in ok) / n
                     if all("over30" in r for r in ok) else None)
    out["time_s"] = sum(r["time_s"] for r in ok) / n
    ratios = [r["time_s"] / ref_time[r["_ref"]] for r in ok
              if ref_time.get(r.get("_ref"), 0) > 0 and r["time_s"] > 0]
    out["ratio"] = math.exp(sum(map(math.log, ratios)) / len(ratios)) if ratios else None
    out["peak_mb"] = max(r["peak_mb"] for r in ok)
    out["delta_mb"] = max(r["peak_mb"] - r["rss_before_mb"] for r in ok)
    out["invalid"] = sum(r["invalid"] for r in ok)
    return out


def fmt(v, spec=".2f", empty="—"):
    return empty if v is None else format(v, spec)


def method_order(key: str) -> tuple:
    m, _, k = key.partition(" k=")
    return (list(METHODS).index(m), int(k) if k else 0)


def summary_table(groups: dict[str, list[dict]], ref_time: dict, notes: dict) -> list[str]:
    lines = ["| method | mean ° | RMS ° | PGP5 % | PGP10 % | > 30° % | time s/cloud | × PCL time | "
             "peak MB | Δ MB | failed pts | clouds |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for key in sorted(groups, key=method_order):
        a = aggregate(groups[key], ref_time)
        m = key.partition(" k=")[0]
        label = METHODS[m][0] + (f" (k={key.partition(' k=')[2]})" if " k=" in key else "")
        if not a.get("ok"):
            why = notes.get(m) or (groups[key][0].get("error", "failed") if groups[key] else "")
            lines.append(f"| {label} | not run: {why} | | | | | | | | | | {a['clouds']} |")
            continue
        errs = f" ({a['errors']} failed)" if a["errors"] else ""
        lines.append(
            f"| {label} | {a['mean_deg']:.2f} | {a['rms_deg']:.2f} | {a['pgp5']:.1f} | "
            f"{a['pgp10']:.1f} | {fmt(a['over30'])} | {a['time_s']:.3f} | {fmt(a['ratio'])} | "
            f"{a['peak_mb']:.0f} | "
            f"{a['delta_mb']:.0f} | {a['invalid']} | {a['ok']}{errs} |")
    return lines


def pct(a: float | None, b: float | None) -> str:
    return "—" if a is None or not b else f"{100.0 * (a / b - 1.0):+.1f} %"


def pcl_best_k(records: list[dict]) -> int | None:
    """PCL's best K among `records` (one category's): the K of the lowest RMS averaged over the
    clouds it ran on without error; None when none did. The bars' rule, also tools/gt_roughness.py's."""
    rms_of: dict[int, list[float]] = {}
    for r in records:
        if r["method"] == "pcl-pca" and "error" not in r:
            rms_of.setdefault(r["k"], []).append(r["rms_deg"])
    return min(sorted(rms_of), key=lambda k: sum(rms_of[k]) / len(rms_of[k]), default=None)


def bar_table(records: list[dict], categories: list[str], ks_of: dict,
              ref_time: dict) -> list[str]:
    """NH-Net against the bars of docs/design/benchmark-protocol.md#bars: RMS against PCA (auto
    k) and against PCL at its best K of the category (the K of lowest RMS among those run),
    mean against mfps (auto scales). Empty when the run has no nhnet records."""
    if not any(r["method"] == "nhnet" for r in records):
        return []

    def stats(rs: list[dict]) -> dict:
        return aggregate(rs, ref_time) if rs else {}

    lines = ["## NH-Net against the bars (RMS first)", "",
             "| category | clouds | nhnet RMS / mean | pca (auto k) RMS | vs pca | PCL best K | "
             "PCL RMS | vs PCL | mfps (auto) mean | vs mfps |", "|---|" + "---|" * 9]
    picked: dict[str, list[dict]] = {"nhnet": [], "pca-auto": [], "pcl": [], "mfps-auto": []}
    for cat in categories + ["Overall"]:
        if cat == "Overall":
            rows, best_k = picked, "per category"
        else:
            of = lambda m, k=0: [r for r in records  # noqa: E731
                                 if r["category"] == cat and r["method"] == m and r["k"] == k]
            best_k = pcl_best_k([r for k in sorted(ks_of[cat]) for r in of("pcl-pca", k)])
            rows = {"nhnet": of("nhnet"), "pca-auto": of("pca-auto"), "mfps-auto": of("mfps-auto"),
                    "pcl": of("pcl-pca", best_k) if best_k is not None else []}
            for key, rs in rows.items():
                picked[key] += rs
        n, p, c, m = (stats(rows[k]) for k in ("nhnet", "pca-auto", "pcl", "mfps-auto"))
        if not n.get("ok"):
            continue
        lines.append(
            f"| {cat} | {n['ok']} | {n['rms_deg']:.2f} / {n['mean_deg']:.2f} | "
            f"{fmt(p.get('rms_deg'))} | {pct(n['rms_deg'], p.get('rms_deg'))} | "
            f"{'—' if best_k is None else best_k} | {fmt(c.get('rms_deg'))} | "
            f"{pct(n['rms_deg'], c.get('rms_deg'))} | {fmt(m.get('mean_deg'))} | "
            f"{pct(n['mean_deg'], m.get('mean_deg'))} |")
    return lines + [""]


def build_report(records: list[dict], meta: dict) -> tuple[list[str], dict]:
    # reference (PCL) time per (cloud, K)
    ref_time = {(r["cloud"], r["k"]): r["time_s"] for r in records
                if r["method"] == REFERENCE and "error" not in r}
    for r in records:
        k = r["k"] or PROTOCOL_K[r["category"]][0]
        r["_ref"] = (r["cloud"], k)
    categories = [c for c in PROTOCOL_K if any(r["category"] == c for r in records)]
    ks_of = {c: category_ks(records, c) for c in categories}
    notes = meta.get("method_notes", {})
    md = [f"# nhnet benchmark ({'quick' if meta['quick'] else 'full'} run)", "",
          f"- date: {meta['date']}", f"- machine: {meta['machine']}",
          f"- command: `{meta['command']}`", f"- commit: {meta['commit']}",
          f"- versions: {meta['versions']}",
          f"- clouds: {meta['clouds']}"
          + (f" of the {meta['clouds_selected']} selected (time budget reached; every category "
             f"and model covered first, see bench/README.md)"
             if meta["clouds"] < meta["clouds_selected"] else "")
          + f" ({meta['points']} points each; models: "
          + "; ".join(f"{c} {len(m)}" for c, m in meta["models"].items() if m)
          + f"), threads per method: "
          f"{meta['threads']}, method processes {meta['children_s']:.0f} s in all (wall of "
          f"this invocation {meta['wall_s']:.0f} s)",
          "", "Errors are unoriented angles in degrees (nhnet metrics), averaged over the "
          "clouds; PGPx = % of points under x°, > 30° % = % of points over 30°. Time: the "
          "estimator call only (wall, mean per cloud), `× PCL time` = geometric mean over clouds of time / PCL "
          "NormalEstimationOMP's time on the same cloud at the same K. Peak MB: the largest "
          "max RSS of the method's own process over the clouds (Δ MB: minus its RSS before the "
          "call, i.e. the method's working memory). K per category: "
          + ", ".join(f"{c} {'/'.join(map(str, PROTOCOL_K[c]))}" for c in categories)
          + (f" (single-K methods also at {'/'.join(map(str, meta['extra_k']))})"
             if meta.get("extra_k") else "")
          + "; `mfps (paper scales)` = {K/2, K, 3K/2} with PCA k = K for smooth points.", ""]
    agg: dict = {}
    for cat in categories:
        groups: dict[str, list[dict]] = {}
        for r in records:
            if r["category"] == cat:
                groups.setdefault(row_key(r, ks_of[cat]), []).append(r)
        md += [f"## {cat}", ""] + summary_table(groups, ref_time, notes) + [""]
        agg[cat] = {key: aggregate(v, ref_time) for key, v in groups.items()}
    # overall: every cloud, each K-dependent method at its category's main K
    groups = {}
    for r in records:
        if METHODS[r["method"]][1] and r["k"] != PROTOCOL_K[r["category"]][0]:
            continue
        groups.setdefault(r["method"], []).append(r)
    md += ["## Overall (every cloud above; main K of each category)", ""] + \
        summary_table(groups, ref_time, notes) + [""]
    agg["Overall"] = {key: aggregate(v, ref_time) for key, v in groups.items()}
    md += bar_table(records, categories, ks_of, ref_time)
    # per noise level
    md += ["## Mean / RMS error (°) per category and noise level", ""]
    for cat in categories:
        levels = sorted({r["noise"] for r in records if r["category"] == cat and r["variant"] ==
                         "uniform"})
        variants = sorted({r["variant"] for r in records if r["category"] == cat} - {"uniform"})
        cols = [("uniform", lv) for lv in levels] + [(v, None) for v in variants]
        md += [f"### {cat}", "",
               "| method | " + " | ".join(f"{lv:g} %" if v == "uniform" else v
                                          for v, lv in cols) + " |",
               "|---|" + "---|" * len(cols)]
        keys = sorted({row_key(r, ks_of[cat]) for r in records if r["category"] == cat},
                      key=method_order)
        for key in keys:
            cells = []
            for v, lv in cols:
                rs = [r for r in records if r["category"] == cat and row_key(r, ks_of[cat]) == key
                      and r["variant"] == v and (lv is None or r["noise"] == lv)
                      and "error" not in r]
                cells.append(f"{sum(r['mean_deg'] for r in rs) / len(rs):.2f} / "
                             f"{sum(r['rms_deg'] for r in rs) / len(rs):.2f}" if rs else "—")
            md.append(f"| {key} | " + " | ".join(cells) + " |")
        md.append("")
    return md, agg


def write_chart(agg: dict, path: Path, title: str) -> str | None:
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:  # python3-matplotlib missing
        return f"no chart: matplotlib not importable ({e})"
    groups = list(agg)  # categories then Overall
    keys = [k for k in METHODS if any(k in agg[g] and agg[g][k].get("ok") for g in groups)]
    if not keys:
        return "no chart: no method produced a result"
    fig, axes = plt.subplots(2, 1, figsize=(max(8, 1.6 * len(groups) + 3), 8.5),
                             gridspec_kw={"height_ratios": [3, 2]})
    width = 0.8 / len(keys)
    cmap = plt.get_cmap("tab10")
    for panel, (ax, field, ylabel) in enumerate(
            [(axes[0], "mean_deg", "mean angle error (°)"),
             (axes[1], "ratio", "time / PCL time (log)")]):
        for j, key in enumerate(keys):
            xs, ys = [], []
            for i, g in enumerate(groups):
                a = agg[g].get(key, {})
                if a.get("ok") and a.get(field) is not None:
                    xs.append(i - 0.4 + width * (j + 0.5))
                    ys.append(a[field])
            bars = ax.bar(xs, ys, width, label=METHODS[key][0], color=cmap(j % 10))
            if panel == 0:
                ax.bar_label(bars, fmt="%.1f", fontsize=6, padding=1)
        ax.set_xticks(range(len(groups)), groups)
        ax.set_ylabel(ylabel)
        ax.grid(axis="y", alpha=0.3)
        if panel == 1:
            ax.set_yscale("log")
            ax.axhline(1.0, color="k", lw=0.8)
    axes[0].set_title(title)
    axes[0].set_ylim(0, axes[0].get_ylim()[1] * 1.3)  # room for the legend above the bars
    axes[0].legend(fontsize=8, ncol=4, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return None


# ----------------------------------------------------------------------------- main

def machine_info() -> str:
    cpu = platform.processor() or "?"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        kb = int(next(ln for ln in open("/proc/meminfo") if ln.startswith("MemTotal")).split()[1])
        mem = f", {kb / 1024 / 1024:.0f} GiB RAM"
    except (OSError, StopIteration):
        pass
    return (f"{platform.node()}: {cpu}, {os.cpu_count()} CPUs{mem}, {platform.system()} "
            f"{platform.release()}, load avg {os.getloadavg()[0]:.1f} at start")


def deb_version(pkg: str) -> str:
    r = subprocess.run(["dpkg-query", "-W", "-f=${Version}", pkg], capture_output=True, text=True)
    return r.stdout.strip() if r.returncode == 0 else "?"


def git_commit() -> str:
    r = subprocess.run(["git", "-C", str(REPO), "describe", "--always", "--dirty"],
                       capture_output=True, text=True)
    return r.stdout.strip() if r.returncode == 0 else "?"


def main(argv: list[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if "--scaling" in args:  # the scaling benchmark (issue 10) has its own options
        import importlib.util
        import types
        spec = importlib.util.spec_from_file_location("nhnet_scaling", REPO / "bench" / "scaling.py")
        scaling = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(scaling)
        return scaling.main(args, types.SimpleNamespace(
            REPO=REPO, datagen=datagen, run_child=run_child, last_json=last_json,
            machine_info=machine_info, git_commit=git_commit))
    ap = argparse.ArgumentParser(prog="nhnet_bench.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true",
                    help=f"CI subset: first model of each paper category at its middle noise "
                         f"level, {QUICK_POINTS} points")
    ap.add_argument("--points", type=int, default=None,
                    help=f"points per cloud (default {FULL_POINTS}; --quick {QUICK_POINTS})")
    ap.add_argument("--categories", default=None,
                    help="comma-separated categories (default the paper's four: "
                         + ",".join(PAPER_CATEGORIES) + "; also PCPNetNoise,PCPNetDensity)")
    ap.add_argument("--models", default=None, help="comma-separated models (default all)")
    ap.add_argument("--levels", default=None, help="comma-separated noise levels in %% "
                    "(default all of each category)")
    ap.add_argument("--methods", default=None,
                    help="comma-separated method ids (default all: " + ",".join(METHODS) + ")")
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1,
                    help="threads of each method (default: all CPUs)")
    ap.add_argument("--data", default=None,
                    help="data directory (nhnet-datagen layout; default "
                         "data/generated/bench-<points>)")
    ap.add_argument("--out", default=None,
                    help="results directory (default build/bench-results[-quick])")
    ap.add_argument("--build", default=str(REPO / "build"),
                    help="build directory with bench/nhnet-bench-worker and cli/nhnet-cli")
    ap.add_argument("--model", default=str(REPO / "models" / "nhnet.pt"),
                    help="NH-Net model of the 'nhnet' method (default: the shipped models/nhnet.pt)")
    ap.add_argument("--open3d-python", default=None,
                    help="python that can import open3d (default: build/bench-venv/bin/python, "
                         "then this python)")
    ap.add_argument("--max-minutes", type=float, default=None,
                    help="start no new cloud after this many minutes; the tables then cover the "
                         "clouds done (say how many) -- the largest part that fits a time budget")
    ap.add_argument("--resume", action="store_true",
                    help="keep the records already in DIR/records.jsonl (an interrupted run "
                         "with the same selection) and run only what is missing")
    ap.add_argument("--extra-k", type=lambda v: [int(x) for x in v.split(",")], default=[],
                    help="comma-separated K values at which the K-dependent methods also run, "
                         "beyond each category's protocol K (e.g. 18,50,100,200: the issue "
                         "bar's 'PCL at its best K')")
    ap.add_argument("--timeout", type=float, default=900.0,
                    help="seconds one method may take on one cloud (default 900)")
    a = ap.parse_args(argv)

    log = lambda msg: print(msg, flush=True)  # noqa: E731
    points = a.points or (QUICK_POINTS if a.quick else FULL_POINTS)
    categories = a.categories.split(",") if a.categories else list(PAPER_CATEGORIES)
    bad = [c for c in categories if c not in PROTOCOL_K]
    if bad:
        ap.error(f"unknown categories {bad}; known: {','.join(PROTOCOL_K)}")
    methods = a.methods.split(",") if a.methods else list(METHODS)
    bad = [m for m in methods if m not in METHODS]
    if bad:
        ap.error(f"unknown methods {bad}; known: {','.join(METHODS)}")
    models = set(a.models.split(",")) if a.models else None
    levels_by_cat: dict[str, list[float]] | None = None
    if a.quick:
        qm, levels_by_cat = quick_selection()
        models = models or set(qm)
        categories = [c for c in categories if c in levels_by_cat] or PAPER_CATEGORIES
    if a.levels:
        lv = [float(x) for x in a.levels.split(",")]
        levels_by_cat = {c: lv for c in categories}
    if models and models - set(datagen.BENCHMARK_MODELS):
        ap.error(f"not benchmark models: {sorted(models - set(datagen.BENCHMARK_MODELS))}")

    build = Path(a.build)
    worker, cli = build / "bench" / "nhnet-bench-worker", build / "cli" / "nhnet-cli"
    for exe in (worker, cli):
        if not os.access(exe, os.X_OK):
            print(f"nhnet_bench: {exe} not built; run: bash scripts/build.sh "
                  f"(it builds the benchmark with -DNHNET_BUILD_BENCH=ON)", file=sys.stderr)
            return 2
    data = Path(a.data) if a.data else REPO / "data" / "generated" / f"bench-{points}"
    out = Path(a.out) if a.out else REPO / "build" / ("bench-results-quick" if a.quick
                                                      else "bench-results")
    out.mkdir(parents=True, exist_ok=True)

    method_notes = {}
    py = None
    model_info = ""
    if any(m.startswith("nhnet") for m in methods):
        model = Path(a.model)
        if not model.is_file():
            print(f"nhnet_bench: {model}: model file not found (--model)", file=sys.stderr)
            return 2
        os.environ["NHNET_MODEL"] = str(model.resolve())  # read by the worker's default model path
        model_info = (f", NH-Net model {model.name} (sha256 "
                      f"{hashlib.sha256(model.read_bytes()).hexdigest()[:12]})")
    o3d_version = "not available" if "open3d" in methods else "not run (not in --methods)"
    if "open3d" in methods:
        py, info = find_open3d_python(a.open3d_python, log)
        if py:
            o3d_version = info
            log(f"open3d {info}: {py}")
        else:
            method_notes["open3d"] = f"open3d not installed/importable ({info}); " \
                                     "install: bash bench/setup-open3d.sh"
            log(f"open3d: NOT AVAILABLE ({info}); the run goes on without it "
                f"(install: bash bench/setup-open3d.sh)")

    t_start = time.perf_counter()
    started = dt.datetime.now(dt.timezone.utc)
    meta = {"quick": a.quick, "date": started.strftime("%Y-%m-%d %H:%M UTC"),
            "machine": machine_info(),
            "command": " ".join(["/usr/bin/python3", "bench/nhnet_bench.py"]
                                + [shlex.quote(x) for x in (argv if argv is not None
                                                            else sys.argv[1:])]),
            "commit": git_commit(), "points": points, "threads": a.threads,
            "versions": f"PCL {deb_version('libpcl-dev')}, CGAL {deb_version('libcgal-dev')}, "
                        f"Open3D {o3d_version}, nanoflann {deb_version('libnanoflann-dev')}"
                        + model_info,
            "method_notes": method_notes, "extra_k": a.extra_k}

    clouds = ensure_data(data, points, categories, models, log)
    clouds = [c for c in clouds if c["category"] in categories
              and (models is None or c["model"] in models)
              and (levels_by_cat is None or c["category"] not in levels_by_cat
                   or c["noise_percent"] in levels_by_cat[c["category"]])]
    if not clouds:
        print("nhnet_bench: no cloud matches the selection", file=sys.stderr)
        return 2
    # Order: round-robin over the categories, and inside a category pass p gives model i its
    # noise level (i + p) mod L, so a run cut short (--max-minutes) has covered every category
    # and model, with every level spread over the models.
    by_cat: dict[str, list[dict]] = {}
    for c in clouds:
        by_cat.setdefault(c["category"], []).append(c)
    for cat, group in by_cat.items():
        mods = list(dict.fromkeys(c["model"] for c in group))
        levs = sorted({(c["variant"], c["noise_percent"]) for c in group})
        group.sort(key=lambda c: ((levs.index((c["variant"], c["noise_percent"]))
                                   - mods.index(c["model"])) % len(levs),
                                  mods.index(c["model"])))
    clouds = [c for group in zip_longest(*by_cat.values()) for c in group if c is not None]
    meta["clouds"] = len(clouds)
    log(f"{len(clouds)} clouds x {len(methods)} methods, {a.threads} threads per method")

    # Every record is appended to records.jsonl as soon as it exists, so --resume can continue.
    jsonl = out / "records.jsonl"
    records: list[dict] = []
    if a.resume and jsonl.exists():
        records = [json.loads(x) for x in jsonl.read_text().splitlines() if x.strip()]
        log(f"resume: {len(records)} records from {jsonl}")
    else:
        jsonl.write_text("")
    done = {(r["cloud"], r["category"], r["method"], r["k"]) for r in records}
    with tempfile.TemporaryDirectory(prefix="nhnet-bench-") as tmp, open(jsonl, "a") as jfh:
        runner = Runner(worker, cli, py, a.threads, a.timeout, Path(tmp))
        for i, c in enumerate(clouds, 1):
            if a.max_minutes is not None and time.perf_counter() - t_start > 60 * a.max_minutes:
                log(f"time budget of {a.max_minutes:g} min reached: stopping after "
                    f"{i - 1} of {len(clouds)} clouds")
                break
            gt = data / "benchmark" / next(f for f in c["files"] if f.endswith(".gt.xyzn"))
            line = []
            for m in methods:
                needs_k = METHODS[m][1]
                ks = run_ks(m, c["category"], a.extra_k)
                for k in ks:
                    if (c["name"], c["category"], m, k) in done:
                        continue
                    rec = runner.run(m, k, gt, c["category"])
                    rec.update(cloud=c["name"], category=c["category"], model=c["model"],
                               noise=c["noise_percent"], variant=c["variant"],
                               points=c["points"])
                    records.append(rec)
                    jfh.write(json.dumps(rec) + "\n")
                    jfh.flush()
                    line.append(f"{m}{'@' + str(k) if needs_k and len(ks) > 1 else ''} "
                                + ("ERR" if "error" in rec else
                                   f"{rec['mean_deg']:.1f}°/{rec['time_s']:.2f}s"))
            log(f"[{i}/{len(clouds)}] {c['category']}/{c['name']}: " + ", ".join(line))
    meta["wall_s"] = time.perf_counter() - t_start
    sel = {c["name"] + "|" + c["category"] for c in clouds}
    records = [r for r in records
               if r["cloud"] + "|" + r["category"] in sel and r["method"] in methods]
    meta["clouds_selected"] = len(clouds)
    meta["children_s"] = sum(r.get("child_wall_s", 0.0) for r in records)
    meta["models"] = {cat: sorted({r["model"] for r in records if r["category"] == cat})
                      for cat in categories}
    meta["clouds"] = len({(r["cloud"], r["category"]) for r in records})
    for r in records:
        if "error" in r and r["method"] != "open3d" or ("error" in r and py):
            log(f"error: {r['method']} k={r['k']} on {r['cloud']}: {r['error']}")

    md, agg = build_report(records, meta)
    (out / "table.md").write_text("\n".join(md) + "\n")
    for r in records:
        r.pop("_ref", None)
    (out / "results.json").write_text(json.dumps({"meta": meta, "records": records,
                                                  "aggregates": agg}, indent=1) + "\n")
    note = write_chart(agg, out / "chart.png",
                       f"nhnet benchmark, mean unoriented angle error ({meta['clouds']} clouds, "
                       f"{points} points)")
    print("\n".join(md))
    if note:
        log(note)
    log(f"wrote {out / 'table.md'}, {out / 'results.json'}"
        + ("" if note else f", {out / 'chart.png'}"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
