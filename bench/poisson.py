"""Screened Poisson surfaces from PCL's and nhnet's normals (issue 57): what the normals and their
confidence do to the surface a MeshLab user gets.

    PYTHONPATH=build/python:training /usr/bin/python3 bench/poisson.py [--out docs/benchmark/poisson]
        [--models fandisk,...] [--levels 0.6,1.2] [--points 20000] [--depth 8] [--threads 2]

Per held-out cloud (nhnet-datagen's PCPNetNoise, `--points` points at each noise level), three
runs of stock MeshLab's "Surface Reconstruction: Screened Poisson" through meshlabserver (its
defaults but the depth; samplesPerNode 1.5):
  1. `pcl`: PCL NormalEstimationOMP k=50 normals (nhnet-bench-worker pcl-pca);
  2. `nhnet`: nhnet's default normals (nhnet.estimate, the shipped model);
  3. `nhnet+conf`: the same normals with their confidence as vertex quality and Screened
     Poisson's confidence flag on (each normal scaled by it), as the MeshLab filter leaves them.
Screened Poisson needs consistent signs: every run's normals are oriented the same way, by
nhnet.orient(mode='mst') (outward on these closed shapes), so the rows differ in their normals
only. The surface's error is the distance of each reconstructed vertex to the true mesh,
measured against a dense sample of it (`--truth-points` points of the same mesh, noise-free;
the distance to the nearest sample overestimates the distance to the surface by at most about
half its spacing, which the table gives), in % of the cloud's bounding-box diagonal: mean and
95th percentile (stray surface Poisson closes across gaps shows in the tail). Writes
OUT/table.md, OUT/results.json and OUT/poisson.png (the first cloud's PCL and nhnet surfaces
coloured by distance).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

import nhnet

REPO = Path(__file__).resolve().parents[1]
MODELS = ["fandisk", "blade", "bunny00", "armadillo", "cow", "mannequin-devil"]
ROWS = ("pcl", "nhnet", "nhnet+conf")


def poisson_mlx(depth: int, confidence: bool) -> str:
    """The filter with every parameter (meshlabserver needs them all, in order); its defaults but
    the depth and the confidence flag."""
    p = [("RichBool", "visibleLayer", "false"), ("RichInt", "depth", str(depth)),
         ("RichInt", "fullDepth", "5"), ("RichInt", "cgDepth", "0"),
         ("RichFloat", "scale", "1.1"), ("RichFloat", "samplesPerNode", "1.5"),
         ("RichFloat", "pointWeight", "4"), ("RichInt", "iters", "8"),
         ("RichBool", "confidence", "true" if confidence else "false"),
         ("RichBool", "preClean", "false")]
    params = "\n".join(f'   <Param type="{t}" name="{n}" value="{v}"/>' for t, n, v in p)
    return ("<!DOCTYPE FilterScript>\n<FilterScript>\n"
            ' <filter name="Surface Reconstruction: Screened Poisson">\n'
            f"{params}\n </filter>\n</FilterScript>\n")


def write_ply(path: Path, pts, nrm, quality=None) -> None:
    cols = [pts, nrm] + ([quality[:, None]] if quality is not None else [])
    names = ["x", "y", "z", "nx", "ny", "nz"] + (["quality"] if quality is not None else [])
    data = np.hstack(cols).astype("<f4")
    head = ("ply\nformat binary_little_endian 1.0\n"
            f"element vertex {len(pts)}\n" + "".join(f"property float {n}\n" for n in names) +
            "end_header\n")
    path.write_bytes(head.encode() + data.tobytes())


def read_ply_mesh(path: Path):
    """Vertices (V x 3) and triangles (F x 3) of a binary little-endian PLY as MeshLab writes
    it (float x y z first; faces as uchar-count int lists)."""
    raw = path.read_bytes()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    head = raw[:end].decode().splitlines()
    nv = nf = 0
    vprops = []
    element = None
    for line in head:
        w = line.split()
        if w[:1] == ["element"]:
            element = w[1]
            if element == "vertex":
                nv = int(w[2])
            elif element == "face":
                nf = int(w[2])
        elif w[:1] == ["property"] and element == "vertex":
            vprops.append((w[2], {"float": "<f4", "double": "<f8", "uchar": "u1",
                                  "int": "<i4"}[w[1]]))
    vt = np.dtype(vprops)
    verts = np.frombuffer(raw, vt, nv, end)
    v = np.stack([verts["x"], verts["y"], verts["z"]], 1).astype(np.float64)
    ft = np.dtype([("n", "u1"), ("i", "<i4", (3,))])
    faces = np.frombuffer(raw, ft, nf, end + vt.itemsize * nv)
    assert np.all(faces["n"] == 3), f"{path}: not a triangle mesh"
    return v, faces["i"].astype(np.int64)


class Display:
    """An Xvfb server for meshlabserver, which needs an X display (a GL context) even headless."""

    def __enter__(self):
        r, w = os.pipe()
        self.proc = subprocess.Popen(["Xvfb", "-displayfd", str(w), "-nolisten", "tcp", "-screen",
                                      "0", "1280x1024x24"], pass_fds=(w,),
                                     stderr=subprocess.DEVNULL)
        os.close(w)
        with os.fdopen(r) as f:
            number = f.readline().strip()
        if not number:
            raise RuntimeError("Xvfb did not start")
        self.env = dict(os.environ, DISPLAY=":" + number)
        return self

    def __exit__(self, *exc):
        self.proc.terminate()
        self.proc.wait()


def reconstruct(work: Path, name: str, pts, nrm, quality, depth: int, env):
    src, out, mlx = work / f"{name}.ply", work / f"{name}.mesh.ply", work / f"{name}.mlx"
    write_ply(src, pts, nrm, quality)
    mlx.write_text(poisson_mlx(depth, quality is not None))
    args = ["meshlabserver", "-i", str(src), "-o", str(out), "-s", str(mlx)]
    r = subprocess.run(args, capture_output=True, text=True, env=env, timeout=900)
    if r.returncode != 0 or not out.exists():
        raise RuntimeError(f"meshlabserver failed on {src}:\n{r.stdout[-2000:]}{r.stderr[-2000:]}")
    return read_ply_mesh(out)


def pcl_normals(work: Path, gt_file: Path, threads: int, build: Path):
    worker = build / "bench" / "nhnet-bench-worker"
    out = work / "pcl.xyzn"
    r = subprocess.run([str(worker), "pcl-pca", "50", str(gt_file), "--threads", str(threads),
                        "--normals-out", str(out)], capture_output=True, text=True, timeout=900)
    if r.returncode != 0:
        raise RuntimeError(f"nhnet-bench-worker pcl-pca failed: {r.stderr}")
    return np.loadtxt(out)[:, 3:6]


def make_data(data: Path, models, levels, points: int, truth_points: int) -> None:
    """The noisy clouds and the dense truth samples (nhnet-datagen; skipped when present)."""
    for pts, sub in ((points, "clouds"), (truth_points, "truth")):
        if (data / sub / "benchmark" / "PCPNetNoise").is_dir():
            continue
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(
            [str(REPO / "training"), os.environ.get("PYTHONPATH", "")]))
        subprocess.run([sys.executable, "-m", "nhnet_training.datagen", "--out", str(data / sub),
                        "--set", "benchmark", "--categories", "PCPNetNoise", "--models",
                        ",".join(models), "--points", str(pts), "--jobs", "1"], check=True,
                       env=env)


def distances(verts, truth_tree, diag):
    d, _ = truth_tree.query(verts)
    return 100 * d / diag


def run_cloud(work: Path, gt_file: Path, truth, args):
    a = np.loadtxt(gt_file)
    pts = a[:, :3]
    diag = float(np.linalg.norm(pts.max(0) - pts.min(0)))
    tree = cKDTree(truth)
    spacing = float(np.mean(tree.query(truth, 2)[0][:, 1]))
    r = nhnet.estimate(pts, orient=None, confidence=True, threads=args.threads)
    normals = {"pcl": pcl_normals(work, gt_file, args.threads, Path(args.build)), "nhnet": r.normals}
    out, meshes = {}, {}
    for row in ROWS:
        n = normals["pcl" if row == "pcl" else "nhnet"]
        ok = np.isfinite(n).all(1)
        oriented = nhnet.orient(pts[ok], n[ok], "mst", threads=args.threads).normals
        q = np.maximum(r.confidence[ok], 1e-3) if row == "nhnet+conf" else None
        v, f = reconstruct(work, row.replace("+", "_"), pts[ok], oriented, q, args.depth,
                           args.display.env)
        d = distances(v, tree, diag)
        err = nhnet.angle_errors(n, a[:, 3:])
        out[row] = {"mean_pct": float(d.mean()), "p95_pct": float(np.percentile(d, 95)),
                    "vertices": int(len(v)), "normal_rms_deg": float(np.sqrt(np.nanmean(err ** 2)))}
        meshes[row] = (v, f, d)
    out["truth_half_spacing_pct"] = 50 * spacing / diag
    return out, meshes


def picture(path: Path, title: str, meshes) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig = plt.figure(figsize=(11, 5.2))
    vmax = max(np.percentile(meshes[r][2], 99) for r in ("pcl", "nhnet"))
    for i, row in enumerate(("pcl", "nhnet")):
        v, f, d = meshes[row]
        ax = fig.add_subplot(1, 2, i + 1, projection="3d")
        tri = ax.plot_trisurf(v[:, 0], v[:, 1], v[:, 2], triangles=f, linewidth=0,
                              antialiased=False, cmap="inferno")
        tri.set_array(d[f].mean(1))
        tri.set_clim(0, vmax)
        ax.set_axis_off()
        ax.set_box_aspect(np.ptp(v, 0))
        label = "PCL k=50 normals" if row == "pcl" else "nhnet normals"
        ax.set_title(f"{label}\nmean {d.mean():.2f} %, p95 {np.percentile(d, 95):.2f} %",
                     fontsize=10)
    cb = fig.colorbar(tri, ax=fig.axes, shrink=0.6)
    cb.set_label("distance to the true mesh, % of the diagonal")
    fig.suptitle(f"Screened Poisson (MeshLab) on {title}")
    fig.savefig(path, dpi=90)
    plt.close(fig)


def table(results) -> str:
    lines = ["| cloud | truth ½ spacing % | " + " | ".join(
        f"{r} mean % | {r} p95 %" for r in ROWS) + " | normal RMS ° pcl / nhnet |",
        "|---|---|" + "---|---|" * len(ROWS) + "---|"]
    for name, r in results.items():
        cells = " | ".join(f"{r[row]['mean_pct']:.3f} | {r[row]['p95_pct']:.3f}" for row in ROWS)
        lines.append(f"| {name} | {r['truth_half_spacing_pct']:.3f} | {cells} | "
                     f"{r['pcl']['normal_rms_deg']:.1f} / {r['nhnet']['normal_rms_deg']:.1f} |")
    mean = {row: (np.mean([r[row]["mean_pct"] for r in results.values()]),
                  np.mean([r[row]["p95_pct"] for r in results.values()])) for row in ROWS}
    cells = " | ".join(f"**{m:.3f}** | **{p:.3f}**" for m, p in mean.values())
    lines.append(f"| **mean over clouds** | | {cells} | |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="docs/benchmark/poisson")
    ap.add_argument("--data", default="runs/poisson")
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--levels", default="0.6,1.2")
    ap.add_argument("--points", type=int, default=20000)
    ap.add_argument("--truth-points", type=int, default=1000000)
    ap.add_argument("--depth", type=int, default=8)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--build", default=os.environ.get("NHNET_BUILD_DIR", str(REPO / "build")),
                    help="build tree with bench/nhnet-bench-worker")
    args = ap.parse_args(argv)
    models, levels = args.models.split(","), args.levels.split(",")
    data, out = Path(args.data), Path(args.out)
    make_data(data, models, levels, args.points, args.truth_points)
    out.mkdir(parents=True, exist_ok=True)
    results, first = {}, None
    with Display() as args.display:
        run_all(args, data, out, models, levels, results)
    (out / "results.json").write_text(json.dumps(results, indent=1) + "\n")
    (out / "table.md").write_text(table(results))
    print(table(results))
    return 0


def run_all(args, data, out, models, levels, results):
    first = None
    for model in models:
        truth = np.loadtxt(data / "truth" / "benchmark" / "PCPNetNoise" / f"{model}_noise0.clean.xyz")
        for level in levels:
            name = f"{model}_noise{level}"
            gt = data / "clouds" / "benchmark" / "PCPNetNoise" / f"{name}.gt.xyzn"
            with tempfile.TemporaryDirectory() as tmp:
                results[name], meshes = run_cloud(Path(tmp), gt, truth, args)
            print(name, json.dumps(results[name]), flush=True)
            if first is None:
                first = name
                picture(out / "poisson.png", name, meshes)


if __name__ == "__main__":
    sys.exit(main())
