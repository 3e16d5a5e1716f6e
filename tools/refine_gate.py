#!/usr/bin/env python3
"""Where NH-Net's network pays: `--refine all` against `--refine moved` per cloud, beside the
noise ratio the pipeline measures (issue 23; ModelOptions::auto_noise_ratio is chosen from this).

    /usr/bin/python3 tools/refine_gate.py run --data DIR --levels 0,0.05,0.1 \\
        [--variants uniform,gradient,stripes] [--cli build/cli/nhnet-cli] --out runs/gate.jsonl
    /usr/bin/python3 tools/refine_gate.py report runs/gate.jsonl [--threshold 0.1]
    PYTHONPATH=build/python /usr/bin/python3 tools/refine_gate.py analytic

`run` estimates every benchmark cloud of DIR (`nhnet-datagen --out DIR --points 20000`; the
benchmark models are never in training) of those levels and variants twice with the whole CLI
(`--method nhnet --orient none --threads 2`), evaluates both against the truth (`nhnet-cli
eval`) and appends one JSON line per cloud (resumable: clouds already in --out are skipped).
`report` prints, per noise-ratio band and per category, the clouds' mean RMS and mean error under
each mode and their difference, then what `--refine auto` with --threshold gives against `all`.
`analytic` estimates fit_candidate_mix.py's smooth closed shapes (sphere, ellipsoid, torus; 20 000
and 5 000 points, noise 0-1.2 %; not in the benchmark, where broad smooth surfaces are rare) with
`nhnet.estimate` under each mode and prints their noise ratio, RMS and mean error.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

BANDS = [0.0, 0.05, 0.1, 0.15, 0.2, 0.3, 0.5, 100.0]


def run_one(cli: str, xyz: Path, gt: Path, refine: str, tmp: Path) -> dict:
    out = tmp / f"{refine}.xyzn"
    est = subprocess.run([cli, "estimate", str(xyz), str(out), "--method", "nhnet", "--refine",
                          refine, "--orient", "none", "--threads", "2", "--overwrite", "--json"],
                         capture_output=True, text=True, check=True)
    summary = json.loads(est.stdout.strip().splitlines()[-1])
    ev = json.loads(subprocess.run([cli, "eval", str(out), str(gt), "--json"],
                                   capture_output=True, text=True, check=True).stdout)
    return dict(rms=ev["rms_deg"], mean=ev["mean_deg"], seconds=summary["seconds"],
                noise_ratio=summary["noise_ratio"])


def cmd_run(a) -> int:
    data = Path(a.data) / "benchmark"
    levels = {float(x) for x in a.levels.split(",")}
    variants = set(a.variants.split(","))
    out = Path(a.out)
    done = set()
    if out.exists():
        done = {json.loads(line)["name"] for line in out.read_text().splitlines() if line.strip()}
    clouds = json.loads((data / "index.json").read_text())["clouds"]
    with out.open("a") as f, tempfile.TemporaryDirectory() as tmp:
        for c in clouds:
            if c["noise_percent"] not in levels or c["variant"] not in variants:
                continue
            if c["name"] in done:
                continue
            xyz, gt = data / c["files"][0], data / c["files"][3]
            rec = dict(name=c["name"], category=c["category"], level=c["noise_percent"],
                       variant=c["variant"])
            for refine in ("all", "moved"):
                rec[refine] = run_one(a.cli, xyz, gt, refine, Path(tmp))
            f.write(json.dumps(rec) + "\n")
            f.flush()
            print(f"{c['name']}: ratio {rec['all']['noise_ratio']:.3f} RMS all "
                  f"{rec['all']['rms']:.2f} moved {rec['moved']['rms']:.2f}", flush=True)
    return 0


def mean(xs: list[float]) -> float:
    return sum(xs) / len(xs) if xs else float("nan")


def mode_means(rs: list[dict]) -> dict:
    """The clouds' mean RMS, mean error and seconds under each mode: col[key][mode]."""
    return {k: {m: mean([r[m][k] for r in rs]) for m in ("all", "moved")}
            for k in ("rms", "mean", "seconds")}


def by_category(recs: list[dict]) -> None:
    """Per category: the clouds' mean RMS and mean error under each mode."""
    print("\n| category | clouds | RMS all | RMS moved | Δ RMS | mean all | mean moved | Δ mean |")
    print("|---|---|---|---|---|---|---|---|")
    for cat in sorted({r["category"] for r in recs}):
        rs = [r for r in recs if r["category"] == cat]
        col = mode_means(rs)
        rms, avg = col["rms"], col["mean"]
        print(f"| {cat} | {len(rs)} | {rms['all']:.2f} | {rms['moved']:.2f} | "
              f"{rms['moved'] - rms['all']:+.2f} | {avg['all']:.2f} | {avg['moved']:.2f} | "
              f"{avg['moved'] - avg['all']:+.2f} |")


def cmd_report(a) -> int:
    recs = [json.loads(line) for line in Path(a.results).read_text().splitlines() if line.strip()]
    print(f"{len(recs)} clouds\n")
    print("| noise ratio | clouds | RMS all | RMS moved | Δ RMS | mean all | mean moved | Δ mean "
          "| s all | s moved |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for lo, hi in zip(BANDS, BANDS[1:]):
        rs = [r for r in recs if lo <= r["all"]["noise_ratio"] < hi]
        if not rs:
            continue
        col = mode_means(rs)
        span = f"{lo:g}-{hi:g}" if hi < 100 else f">= {lo:g}"
        print(f"| {span} | {len(rs)} | {col['rms']['all']:.2f} | {col['rms']['moved']:.2f} | "
              f"{col['rms']['moved'] - col['rms']['all']:+.2f} | {col['mean']['all']:.2f} | "
              f"{col['mean']['moved']:.2f} | {col['mean']['moved'] - col['mean']['all']:+.2f} | "
              f"{col['seconds']['all']:.1f} | {col['seconds']['moved']:.1f} |")
    by_category(recs)
    gated = [r for r in recs if r["all"]["noise_ratio"] < a.threshold]
    auto = [r["moved"] if r in gated else r["all"] for r in recs]
    worst = max(gated, key=lambda r: r["moved"]["rms"] - r["all"]["rms"], default=None)
    print(f"\n--refine auto, threshold {a.threshold:g}: {len(gated)} of {len(recs)} clouds take "
          f"the moved mode; over all clouds RMS {mean([r['all']['rms'] for r in recs]):.3f} -> "
          f"{mean([x['rms'] for x in auto]):.3f}, mean "
          f"{mean([r['all']['mean'] for r in recs]):.3f} -> {mean([x['mean'] for x in auto]):.3f}, "
          f"seconds {sum(r['all']['seconds'] for r in recs):.0f} -> "
          f"{sum(x['seconds'] for x in auto):.0f}")
    if worst:
        print(f"largest RMS change among them: {worst['name']} "
              f"{worst['all']['rms']:.2f} -> {worst['moved']['rms']:.2f}")
    return 0


def cmd_analytic(a) -> int:
    import numpy as np

    import nhnet
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from fit_candidate_mix import analytic_clouds
    for shape, n, level, pts, truth in analytic_clouds():
        cols = []
        for refine in ("all", "moved"):
            r = nhnet.estimate(pts, refine=refine, orient=None, threads=a.threads)
            err = nhnet.angle_errors(r.normals, truth)
            cols.append(f"{refine} RMS {np.sqrt(np.mean(err * err)):6.2f} mean {err.mean():6.2f}")
        print(f"{shape} {n} {level:g} %: ratio {r.noise_ratio:.3f}  " + "  ".join(cols), flush=True)
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--data", required=True)
    r.add_argument("--levels", default="0")
    r.add_argument("--variants", default="uniform")
    r.add_argument("--cli", default="build/cli/nhnet-cli")
    r.add_argument("--out", required=True)
    p = sub.add_parser("report")
    p.add_argument("results")
    p.add_argument("--threshold", type=float, default=0.1)
    an = sub.add_parser("analytic")
    an.add_argument("--threads", type=int, default=1)
    a = ap.parse_args()
    return {"run": cmd_run, "report": cmd_report, "analytic": cmd_analytic}[a.cmd](a)


if __name__ == "__main__":
    sys.exit(main())
