"""Golden outputs of every method and front end on two fixed clouds (issue 26): the guard that a
restructure changes no result.

Each case runs one front end on a fixed cloud and returns arrays; `make_golden.py` stores them in
expected.npz, tests/python/test_golden.py recomputes them and compares. Front ends covered here:
nhnet-cli (estimate with every method, orientation mode, the in-memory tiling and the streamed
path; denoise; eval) and the Python module (estimate, orient, denoise, describe). The PCL class is
compared against the same file by tests/pcl (GoldenMatchesCli); the MeshLab and CloudCompare
plugins are compared against nhnet-cli by their own tests, so they are covered through it.

Clouds: the first 4000 points of the bundled noisy fandisk sample (its points are in random order,
so this is a random subset), and the first 3000 of its clean copy.
"""

import json
import os
import subprocess
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("NHNET_BUILD_DIR", REPO / "build"))
CLI = BUILD / "cli" / "nhnet-cli"
SAMPLE = REPO / "data" / "sample"
EXPECTED = Path(__file__).resolve().parent / "expected.npz"

NOISY_POINTS = 4000
CLEAN_POINTS = 3000


def _head(src, n, dst):
    with open(src) as f, open(dst, "w") as g:
        for _, line in zip(range(n), f):
            g.write(line)


def _read(path):
    import nhnet

    cloud = nhnet.read(str(path))
    return np.asarray(cloud.points), np.asarray(cloud.normals)


# The network's cases in float32: the default precision, auto, takes bfloat16 on CPUs with
# AVX512-BF16, and the expected outputs must hold on every machine.
F32 = ("--precision", "float32")


def _cli(*args):
    subprocess.run([str(CLI), *map(str, args), "--quiet", "--overwrite"], check=True)


def _cli_cases(work, out):
    noisy, clean, gt = work / "noisy.xyz", work / "clean.xyz", work / "gt.xyzn"
    estimates = {
        "cli_pca": (noisy, "--method", "pca", "--orient", "none"),
        "cli_mfps": (noisy, "--method", "mfps", "--orient", "none"),
        "cli_nhnet": (noisy, "--method", "nhnet", "--orient", "none", *F32),
        "cli_default_mst": (noisy, *F32),
        "cli_mfps_mst_k30": (noisy, "--method", "mfps", "--orient", "mst:30"),
        "cli_pca_viewpoint": (noisy, "--method", "pca", "--orient", "viewpoint", "0", "0", "2"),
        "cli_pca_keep": (gt, "--method", "pca"),
        "cli_mfps_tiled": (noisy, "--method", "mfps", "--orient", "none", "--tile-points", "1500"),
        "cli_nhnet_tiled": (noisy, "--method", "nhnet", "--orient", "none", "--tile-points", "1500",
                            *F32),
        "cli_mfps_stream": (noisy, "--method", "mfps", "--stream", "--tile-points", "1500"),
        "cli_pca_clean_k12": (clean, "--method", "pca", "-k", "12", "--orient", "none"),
        "cli_mfps_clean_scales": (clean, "--method", "mfps", "--scales", "20,40,60", "--orient", "none"),
    }
    for name, (src, *opts) in estimates.items():
        dst = work / f"{name}.ply"
        _cli("estimate", src, dst, *opts)
        out[name + "_normals"] = _read(dst)[1]
    _cli("denoise", noisy, work / "denoised.ply", "--normals-from", "mfps", "--keep-normals")
    points, normals = _read(work / "denoised.ply")
    out["cli_denoise_mfps_points"], out["cli_denoise_mfps_normals"] = points, normals
    _cli("denoise", noisy, work / "denoised_default.xyz", *F32)
    out["cli_denoise_default_points"] = _read(work / "denoised_default.xyz")[0]
    _cli("estimate", noisy, work / "for_eval.xyzn", "--method", "mfps", "--orient", "none")
    res = subprocess.run([str(CLI), "eval", work / "for_eval.xyzn", gt, "--json"], check=True,
                         capture_output=True, text=True)
    ev = json.loads(res.stdout)
    out["cli_eval"] = np.array([float(ev[k]) for k in sorted(ev) if isinstance(ev[k], (int, float))])


def _python_cases(work, out):
    import nhnet

    pts = _read(work / "noisy.xyz")[0]
    for method in ("pca", "mfps", "nhnet"):
        r = nhnet.estimate(pts, method=method, precision="float32")
        out[f"py_{method}_normals"] = np.asarray(r.normals)
        out[f"py_{method}_curvature"] = np.asarray(r.curvature)
    mfps = out["py_mfps_normals"].copy()
    out["py_orient_mst"] = np.asarray(nhnet.orient(pts, mfps, "mst").normals)
    out["py_orient_viewpoint"] = np.asarray(
        nhnet.orient(pts, mfps, "viewpoint", viewpoint=(0.0, 0.0, 2.0)).normals)
    d = nhnet.denoise(pts, mfps)
    out["py_denoise_points"] = np.asarray(d.points)
    for version, key in ((1, "py_describe"), (2, "py_describe_v2")):  # v2: capped neighbours
        desc = nhnet.descriptors(pts[:1500], version=version)
        out[key + "_features"] = np.asarray(desc["features"])[::25]
        out[key + "_rotations"] = np.asarray(desc["rotations"])[::25]


def compute():
    """Runs every case; returns {name: float array}."""
    out = {}
    with tempfile.TemporaryDirectory(prefix="nhnet-golden-") as tmp:
        work = Path(tmp)
        _head(SAMPLE / "fandisk_noise0.6.xyz", NOISY_POINTS, work / "noisy.xyz")
        _head(SAMPLE / "fandisk_noise0.6.clean.xyz", CLEAN_POINTS, work / "clean.xyz")
        _head(SAMPLE / "fandisk_noise0.6.gt.xyzn", NOISY_POINTS, work / "gt.xyzn")
        _cli_cases(work, out)
        _python_cases(work, out)
    return {k: np.asarray(v, dtype=np.float64) for k, v in out.items()}
