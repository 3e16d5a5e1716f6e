"""Accuracy against whole-process time for sizes of the learned stage (issue 23: "if accuracy and
speed trade off, commit the measured front, RMS vs time, >= 4 model sizes").

    /usr/bin/python3 bench/front.py --clouds f1m_0.0.gt.xyzn,f1m_0.6.gt.xyzn \\
        --sizes mfps,mix,h8=runs/front/h8.inc,h16,h32=runs/front/h32.inc \\
        [--reference docs/benchmark/nhnet-v7/records.jsonl] [--out docs/benchmark/front]

Sizes, smallest first: `mfps` (`--method mfps`, no network), `mix` (NH-Net and the candidate
mix: `--learned-fit off`), `h16` (the shipped learned fit) and `NAME=FILE`, the same fit with the
weights of FILE (`tools/fit_learned_fit.py fit ... --hidden H --write FILE`). `@MODEL` after a
size runs it with another NH-Net model file (`v6@models/nhnet-v6.pt`: the shipped fit on the
larger v6 network; the network's size, where the others vary the fit's). For each size this
builds nhnet-cli and nhnet-bench-worker with its weights (CMake NHNET_LEARNED_FIT_WEIGHTS: only
learned_fit.cpp recompiles) and keeps copies of them; the shipped weights are then built back
(also after a failure). Then, size after size, it times the whole `nhnet-cli estimate CLOUD.xyz
OUT.xyzn --threads 2` process (read, estimate, MST orientation, write) on each --clouds cloud
between two PCL `NormalEstimationOMP` (k=50) processes (tools/ab_timing.py's way), and last runs
bench/nhnet_bench.py on the whole test split with each size's programs.

Writes OUT/table.md and OUT/results.json: per category and size the mean over clouds of RMS and
mean error, the RMS against the reference run's pca-auto and PCL best K (the same clouds), and
each size's whole-process time as a multiple of PCL's on each timing cloud.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(REPO / "tools"), str(REPO / "bench")]
from ab_timing import run, xyz_of  # noqa: E402
import nhnet_bench  # noqa: E402

CATEGORIES = list(nhnet_bench.PROTOCOL_K)  # the test split's categories, in the tables' order
SHIPPED = "h16"  # the size whose weights are core/src/learned/learned_fit_weights.inc


def parse_sizes(text: str) -> list[tuple[str, str, str]]:
    """(name, weights file or '', model file or '') for each NAME[=WEIGHTS][@MODEL]; mfps and
    mix take no weights, mfps no model; a size with a model of its own may keep the shipped fit."""
    out = []
    for item in text.split(","):
        head, _, model = item.partition("@")
        name, _, path = head.partition("=")
        for file, what in ((path, "weights"), (model, "model")):
            if file and not Path(file).is_file():
                sys.exit(f"front: {file}: {what} file not found (size {name})")
        if model and name == "mfps":
            sys.exit("front: size mfps runs no network (no @MODEL)")
        if not path and not model and name not in ("mfps", "mix", SHIPPED):
            sys.exit(f"front: size {name} needs a weights file (NAME=FILE) or a model (NAME@MODEL)")
        out.append((name, str(Path(path).resolve()) if path else "",
                    str(Path(model).resolve()) if model else ""))
    return out


def build(build_dir: Path, weights: str) -> None:
    """Configures the fit's weights and builds the two programs the front runs."""
    for cmd in (["cmake", "-S", str(REPO), "-B", str(build_dir),
                 f"-DNHNET_LEARNED_FIT_WEIGHTS={weights}"],
                ["cmake", "--build", str(build_dir), "--target", "nhnet-cli",
                 "nhnet-bench-worker"]):
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def programs(build_dir: Path, into: Path) -> Path:
    """Copies of the two programs just built (they link the core statically), laid out as a
    build directory, so every size keeps its own while the build directory moves on."""
    for sub, exe in (("cli", "nhnet-cli"), ("bench", "nhnet-bench-worker")):
        (into / sub).mkdir(parents=True, exist_ok=True)
        shutil.copy2(build_dir / sub / exe, into / sub / exe)
    return into


def model_args(model: str) -> list[str]:
    """The model option of nhnet-cli and bench/nhnet_bench.py alike; none for the shipped model."""
    return ["--model", model] if model else []


def cli_args(name: str, model: str = "") -> list[str]:
    return ({"mfps": ["--method", "mfps"], "mix": ["--learned-fit", "off"]}.get(name, [])
            + model_args(model))


def bench_method(name: str) -> str:
    return {"mfps": "mfps-auto", "mix": "nhnet-mix"}.get(name, "nhnet")


def time_size(build_dir: Path, name: str, model: str, clouds: list[Path], tmp: Path,
              threads: int) -> dict:
    """Whole-process seconds of the size and of PCL around it, per timing cloud."""
    cli, worker = build_dir / "cli" / "nhnet-cli", build_dir / "bench" / "nhnet-bench-worker"
    out = {}
    for gt in clouds:
        xyz = xyz_of(gt, tmp)
        pcl = [str(worker), "pcl-pca", "50", str(gt), "--threads", str(threads)]
        before = run(pcl)[0]
        wall = run([str(cli), "estimate", str(xyz), str(tmp / "out.xyzn"), "--threads",
                    str(threads), "--overwrite", "--quiet"] + cli_args(name, model))[0]
        after = run(pcl)[0]
        out[gt.name] = {"seconds": wall, "pcl_seconds": (before + after) / 2,
                        "ratio": wall / ((before + after) / 2)}
        print(f"front: {name} {gt.name}: {wall:.1f} s, {out[gt.name]['ratio']:.2f}x PCL",
              flush=True)
    return out


def accuracy(build_dir: Path, name: str, model: str, work: Path, threads: int,
             categories: list[str]) -> dict:
    """Per category: mean over the test split's clouds of RMS and mean error (bench/nhnet_bench.py)."""
    method, out = bench_method(name), work / f"bench-{name}"
    subprocess.run([sys.executable, str(REPO / "bench" / "nhnet_bench.py"), "--categories",
                    ",".join(categories), "--methods", method, "--threads", str(threads),
                    "--build", str(build_dir), "--out", str(out)] + model_args(model),
                   check=True,
                   stdout=subprocess.DEVNULL)
    return per_category([json.loads(line) for line in (out / "records.jsonl").open()], method)


def per_category(records: list[dict], method: str, k: int | None = None) -> dict:
    rows = {}
    for c in CATEGORIES:
        rs = [r for r in records if r["method"] == method and r["category"] == c
              and "rms_deg" in r and (k is None or r["k"] == k)]
        if rs:
            agg = nhnet_bench.aggregate(rs, {})  # the bench tables' means over clouds
            rows[c] = {"rms": agg["rms_deg"], "mean": agg["mean_deg"], "clouds": agg["ok"]}
    return rows


def references(path: Path) -> dict:
    """pca-auto's and PCL's best single K's RMS per category from a committed bench run."""
    records = [json.loads(line) for line in path.open()]
    pca = per_category(records, "pca-auto")
    ks = sorted({r["k"] for r in records if r["method"] == "pcl-pca"})
    pcl = {k: per_category(records, "pcl-pca", k) for k in ks}
    best = {c: min((pcl[k][c]["rms"], k) for k in ks if c in pcl[k]) for c in CATEGORIES}
    return {c: {"pca_auto": pca[c]["rms"], "pcl_best": best[c][0], "pcl_best_k": best[c][1]}
            for c in CATEGORIES}


def report(res: dict) -> str:
    sizes, refs = res["sizes"], res["references"]
    cats = [c for c in CATEGORIES if all(c in s.get("accuracy", {}) for s in sizes.values())]
    md = ["# Front: accuracy against whole-process time of the learned stage's sizes", "",
          f"- date: {res['date']}; commit {res['commit']}; threads 2",
          f"- command: `{res['command']}`",
          f"- accuracy: bench/nhnet_bench.py on the whole test split (mean over clouds); "
          f"references (pca-auto, PCL best single K) from `{res['reference']}`",
          "- time: the whole `nhnet-cli estimate` process (read, estimate, MST orientation, "
          "write) / PCL NormalEstimationOMP (k=50) as a process, the mean of the runs just "
          "before and after"]
    own = [f"{n} {s['model']}" for n, s in sizes.items() if s.get("model")]
    md += ([f"- NH-Net model: the shipped one, but {', '.join(own)}"] if own else []) + [
          "",
          "| size | " + " | ".join(f"{c} RMS / mean" for c in cats)
          + " | categories' mean RMS / mean | " + " | ".join(f"× PCL {c}" for c in res["clouds"]) + " |",
          "|---|" + "---|" * (len(cats) + 1 + len(res["clouds"]))]
    for name, s in sizes.items():
        acc = s["accuracy"]
        cells = [f"{acc[c]['rms']:.2f} / {acc[c]['mean']:.2f}" for c in cats]
        allr = statistics.mean(acc[c]["rms"] for c in cats)
        allm = statistics.mean(acc[c]["mean"] for c in cats)
        times = [f"{s['time'][c]['ratio']:.2f} ({s['time'][c]['seconds']:.0f} s)"
                 for c in res["clouds"]]
        md.append(f"| {name} | " + " | ".join(cells) + f" | {allr:.2f} / {allm:.2f} | "
                  + " | ".join(times) + " |")
    md += ["", "RMS against the references (negative = below; the issue's bars: ≤ −10 % against "
           "pca-auto, ≤ −20 % against PCL's best K, every category):", "",
           "| size | " + " | ".join(f"{c} vs pca-auto / PCL best K" for c in cats) + " |",
           "|---|" + "---|" * len(cats)]
    for name, s in sizes.items():
        acc = s["accuracy"]
        md.append(f"| {name} | " + " | ".join(
            f"{100 * (acc[c]['rms'] / refs[c]['pca_auto'] - 1):+.1f} % / "
            f"{100 * (acc[c]['rms'] / refs[c]['pcl_best'] - 1):+.1f} %" for c in cats) + " |")
    md += ["", "References: " + "; ".join(
        f"{c} pca-auto {refs[c]['pca_auto']:.2f}, PCL k={refs[c]['pcl_best_k']} "
        f"{refs[c]['pcl_best']:.2f}" for c in cats), ""]
    return "\n".join(md)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--clouds", required=True, help="comma-separated .gt.xyzn timing clouds")
    ap.add_argument("--sizes", default="mfps,mix,h16")
    ap.add_argument("--reference", default=str(REPO / "docs" / "benchmark" / "nhnet-v7" / "records.jsonl"))
    ap.add_argument("--build", default=str(REPO / "build"))
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--categories", default=",".join(CATEGORIES),
                    help="test split categories (default all; fewer for a quick look)")
    ap.add_argument("--out", default=str(REPO / "build" / "front"))
    a = ap.parse_args(argv)
    sizes, clouds = parse_sizes(a.sizes), [Path(c) for c in a.clouds.split(",")]
    for c in clouds:
        if not c.is_file():
            sys.exit(f"front: {c}: timing cloud not found")
    build_dir, out = Path(a.build), Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    res = {"date": dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
           "commit": commit, "command": "bench/front.py " + " ".join(argv or sys.argv[1:]),
           "reference": Path(a.reference).name, "clouds": [c.name for c in clouds],
           "references": references(Path(a.reference)), "sizes": {}}
    with tempfile.TemporaryDirectory() as tmp:
        bins = {}
        try:
            for name, weights, _ in sizes:
                build(build_dir, weights)
                bins[name] = programs(build_dir, Path(tmp) / f"bin-{name}")
        finally:
            build(build_dir, "")
        # Timing first, all sizes one after the other (the machine must be idle), then accuracy.
        for name, weights, model in sizes:
            res["sizes"][name] = {"weights": Path(weights).name if weights else "",
                                  "model": Path(model).name if model else "",
                                  "time": time_size(bins[name], name, model, clouds, Path(tmp),
                                                    a.threads)}
        print("front: timing done; accuracy on the test split follows", flush=True)
        for name, _, model in sizes:
            res["sizes"][name]["accuracy"] = accuracy(bins[name], name, model, Path(tmp),
                                                      a.threads, a.categories.split(","))
            (out / "results.json").write_text(json.dumps(res, indent=1) + "\n")
    (out / "table.md").write_text(report(res))
    print(report(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
