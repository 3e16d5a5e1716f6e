"""Tests of the Python bindings (module `nhnet`, python/): analytic normals, error mapping,
io round trips, cancellation, the GIL, and agreement with nhnet-cli.

Run by scripts/test.sh with PYTHONPATH=build/python; NHNET_BUILD_DIR (default <repo>/build)
locates nhnet-cli.
"""

import json
import math
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import nhnet

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("NHNET_BUILD_DIR", REPO / "build"))
CLI = BUILD / "cli" / "nhnet-cli"
SAMPLE = REPO / "data" / "sample" / "fandisk_noise0.6.xyz"


def angles_deg(a, b):
    """Unoriented angle between rows of a and b, degrees."""
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.abs(np.sum(a * b, axis=1)), 0.0, 1.0)))


def tilted_plane(n=3000, seed=0):
    rng = np.random.default_rng(seed)
    uv = rng.uniform(-1.0, 1.0, (n, 2))
    e1 = np.array([1.0, 0.0, 0.5])
    e2 = np.array([0.2, 1.0, -0.3])
    normal = np.cross(e1, e2)
    normal /= np.linalg.norm(normal)
    return uv[:, :1] * e1 + uv[:, 1:] * e2 + np.array([3.0, -2.0, 1.0]), normal


def sphere(n=4000, seed=1):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    return p


# ---------------------------------------------------------------------------------------------
# Analytic normals


@pytest.mark.parametrize("method", ["pca", "mfps"])
def test_plane_normals_exact(method):
    pts, normal = tilted_plane()
    n = nhnet.estimate_normals(pts, method=method, threads=2)
    assert n.shape == pts.shape and n.dtype == np.float64
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-9)
    # Noise-free plane: every neighbourhood is exactly planar, so only rounding error remains;
    # 0.01 degrees is orders of magnitude above double rounding and far below any real error.
    assert angles_deg(n, np.tile(normal, (len(pts), 1))).max() < 0.01


def test_sphere_normals_radial():
    pts = sphere()
    r = nhnet.estimate(pts, method="pca", k=20, threads=2)
    assert r.failed == 0 and r.valid.all() and r.k_used == 20
    err = angles_deg(r.normals, pts)
    # 4000 points on the unit sphere: 20 neighbours span a cap of ~8 degrees of arc, and PCA
    # of a one-sided cap tilts by a fraction of that. Measured mean 0.79, worst 3.7 degrees;
    # bounds 1.5 / 6 (a wrong axis would be ~57 on average, a wrong k a few degrees more).
    assert err.mean() < 1.5
    assert err.max() < 6.0


def test_sphere_mfps_close_to_radial():
    pts = sphere()
    n = nhnet.estimate_normals(pts, method="mfps", scales=[20, 40], k=20, threads=2)
    # A smooth surface: MFPS must not do worse than PCA's bound above by more than its larger
    # patch (40 neighbours, ~11 degrees of arc) allows. Measured mean 0.91; bound 2 degrees.
    assert angles_deg(n, pts).mean() < 2.0


def test_dense_noisy_cloud_through_cell_means():
    # 200 000 points of the unit sphere (spacing ~0.008) with radial noise 0.03: noise ratio
    # ~1.17, above the 1.12 threshold, so the default estimates cell means (cell_means.cpp).
    rng = np.random.default_rng(3)
    truth = sphere(200000, seed=2)
    pts = truth * (1 + 0.03 * rng.normal(size=(len(truth), 1)))
    on = nhnet.estimate(pts, method="pca", threads=2, orient=None)
    off = nhnet.estimate(pts, method="pca", threads=2, orient=None, cell_means=False)
    assert on.noise_ratio >= 1 and off.cell_means == 0
    assert 10000 < on.cell_means < 100000 and on.failed == 0
    # The means average their cubes' noise as the large neighbourhood does: RMS within half a
    # degree of the points' own estimate (a wrong mean per point would be tens of degrees).
    def rms(n):
        return float(np.sqrt(np.mean(angles_deg(n, truth) ** 2)))
    assert rms(on.normals) < rms(off.normals) + 0.5
    # A number is the noise ratio from which: 50 leaves the cloud to its points, 0.5 averages.
    assert nhnet.estimate(pts, method="pca", threads=2, orient=None, cell_means=50.0).cell_means == 0
    assert nhnet.estimate(pts, method="pca", threads=2, orient=None, cell_means=0.5).cell_means > 0
    # nhnet-cli's words, through the core's one parser.
    assert nhnet.estimate(pts, method="pca", threads=2, orient=None, cell_means="off").cell_means == 0
    assert nhnet.estimate(pts, method="pca", threads=2, orient=None, cell_means="0.5").cell_means > 0
    for bad in (0, -1.0, float("nan"), "maybe", "", None):
        with pytest.raises(nhnet.InvalidOptions, match="cell_means must be auto, off"):
            nhnet.estimate(pts[:100], method="pca", cell_means=bad)


def test_full_result_fields_and_non_finite_points():
    pts, normal = tilted_plane(2000)
    pts[5] = [np.nan, 0, 0]
    pts[7] = [np.inf, 1, 2]
    r = nhnet.estimate(pts, method="mfps", threads=1)
    assert r.failed == 2
    assert r.valid.dtype == np.bool_ and r.valid.shape == (2000,)
    assert not r.valid[5] and not r.valid[7] and r.valid.sum() == 1998
    assert np.isnan(r.normals[5]).all() and np.isnan(r.normals[7]).all()
    assert np.isfinite(r.normals[r.valid]).all()
    # curvature = PCA surface variation: ~0 on an exact plane (rounding only), NaN where failed
    assert r.curvature.shape == (2000,) and np.isnan(r.curvature[[5, 7]]).all()
    assert np.nanmax(r.curvature) < 1e-12
    assert r.noise_ratio >= 0 and r.spacing > 0 and r.k_used >= 3
    assert len(r.scales_used) > 0
    assert any("non-finite" in w for w in r.warnings)
    with pytest.warns(RuntimeWarning, match="non-finite"):
        nhnet.estimate_normals(pts, method="pca", k=10)


def test_seed_determinism_and_thread_independence():
    pts = sphere(3000)
    a = nhnet.estimate_normals(pts, method="mfps", threads=1, seed=7, scales=[20, 40])
    b = nhnet.estimate_normals(pts, method="mfps", threads=2, seed=7, scales=[20, 40])
    np.testing.assert_array_equal(a, b)


def test_orient_flips_to_reference():
    pts = sphere(2000)
    n = nhnet.estimate(pts, method="pca", k=15, orient=pts)  # outward reference
    assert np.all(np.sum(n.normals * pts, axis=1) > 0)
    inward = nhnet.estimate_normals(pts, method="pca", k=15, orient=-pts)
    np.testing.assert_allclose(inward, -n.normals)


def test_accepts_float32_and_lists():
    pts, normal = tilted_plane(500)
    a = nhnet.estimate_normals(pts.astype(np.float32), method="pca", k=10)
    b = nhnet.estimate_normals(pts.astype(np.float32).astype(np.float64).tolist(),
                               method="pca", k=10)
    np.testing.assert_array_equal(a, b)


# ---------------------------------------------------------------------------------------------
# Errors: core exception types -> Python classes with the core's message


def test_invalid_options_are_value_errors():
    pts, _ = tilted_plane(100)
    with pytest.raises(nhnet.InvalidOptions, match="unknown method 'foo'"):
        nhnet.estimate_normals(pts, method="foo")
    with pytest.raises(ValueError, match="k must be 0 .auto. or at least 3, got 2"):
        nhnet.estimate_normals(pts, k=2)
    with pytest.raises(nhnet.InvalidOptions, match="scale must be at least 4"):
        nhnet.estimate_normals(pts, scales=[50, 2])
    with pytest.raises(nhnet.InvalidOptions, match=r"points must be an \(N, 3\) array, got shape \(100, 2\)"):
        nhnet.estimate_normals(pts[:, :2])
    with pytest.raises(nhnet.InvalidOptions, match="array of numbers, got str"):
        nhnet.estimate_normals("not points")
    with pytest.raises(nhnet.InvalidOptions, match="one reference normal per point"):
        nhnet.estimate_normals(pts, orient=pts[:10])
    assert issubclass(nhnet.InvalidOptions, nhnet.Error)


def test_unprocessable_input():
    pts = np.array([[0, 0, 0], [1, 0, 0], [np.nan, 0, 0], [0, 1, np.inf]], float)
    with pytest.raises(nhnet.UnprocessableInput, match="only 2 finite points"):
        nhnet.estimate_normals(pts)
    with pytest.raises(ValueError):
        nhnet.estimate_normals(np.zeros((0, 3)))


def test_input_errors_name_the_file(tmp_path):
    missing = tmp_path / "nope.ply"
    with pytest.raises(nhnet.InputError, match="nope.ply"):
        nhnet.read(str(missing))
    with pytest.raises(OSError):  # InputError is also an OSError
        nhnet.read(str(missing))
    bad = tmp_path / "bad.xyz"
    bad.write_text("1 2 3\n4 5 six\n")
    with pytest.raises(nhnet.InputError, match=r"bad.xyz.*line 2"):
        nhnet.read(str(bad))
    trunc = tmp_path / "trunc.ply"
    trunc.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 10\n"
                      b"property float x\nproperty float y\nproperty float z\nend_header\n"
                      + b"\0" * 20)
    with pytest.raises(ValueError, match="trunc.ply"):
        nhnet.read(str(trunc))


def test_output_errors(tmp_path):
    pts, _ = tilted_plane(10)
    with pytest.raises(nhnet.OutputError, match="no_such_dir"):
        nhnet.write(str(tmp_path / "no_such_dir" / "a.ply"), pts)
    with pytest.raises(nhnet.OutputError, match="cannot tell the output format"):
        nhnet.write(str(tmp_path / "a.unknown"), pts)
    with pytest.raises(nhnet.InvalidOptions, match="unknown format 'obj'"):
        nhnet.write(str(tmp_path / "a.ply"), pts, format="obj")
    assert not list(tmp_path.iterdir())  # nothing partial left behind
    with pytest.raises(nhnet.InvalidOptions, match="one row per point"):
        nhnet.write(str(tmp_path / "a.ply"), pts, pts[:3])


# ---------------------------------------------------------------------------------------------
# io round trips


@pytest.mark.parametrize("name,ascii", [("c.ply", False), ("c.ply", True), ("c.pcd", False),
                                        ("c.pcd", True), ("c.xyz", False)])
def test_read_write_round_trip(tmp_path, name, ascii):
    rng = np.random.default_rng(3)
    pts = rng.normal(size=(257, 3)) * 100
    nrm = rng.normal(size=(257, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    extras = {} if name.endswith(".xyz") else {
        "red": rng.integers(0, 256, 257).astype(np.uint8),
        "intensity": rng.uniform(0, 1, 257).astype(np.float32)}
    path = tmp_path / name
    nhnet.write(str(path), pts, nrm, extras=extras, ascii=ascii)
    c = nhnet.read(str(path))
    assert len(c) == 257 and c.points.shape == (257, 3)
    # PLY / PCD hold coordinates as double when given double, normals as float32
    # (relative error <= 6e-8); XYZ text is written at full precision.
    np.testing.assert_allclose(c.points, pts, rtol=1e-7)
    np.testing.assert_allclose(c.normals, nrm, atol=1e-6)
    assert sorted(c.extras) == sorted(extras)
    for k, v in extras.items():
        assert c.extras[k].dtype == v.dtype
        np.testing.assert_array_equal(c.extras[k], v)
    # A Cloud writes back as itself.
    again = tmp_path / ("again_" + name)
    nhnet.write(str(again), c, ascii=ascii)
    d = nhnet.read(str(again))
    np.testing.assert_array_equal(d.points, c.points)
    np.testing.assert_array_equal(d.normals, c.normals)


def test_read_without_normals(tmp_path):
    path = tmp_path / "p.xyz"
    path.write_text("0 0 0\n1 0 0\n0 1 0\n")
    c = nhnet.read(str(path))
    assert c.normals is None and c.extras == {}
    np.testing.assert_array_equal(c.points, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])


def test_metrics_match_definition():
    gt = np.tile([0.0, 0.0, 1.0], (4, 1))
    est = np.array([[0, 0, -1.0], [0, math.sin(math.radians(7)), math.cos(math.radians(7))],
                    [0, 1.0, 0], [np.nan, 0, 0]])
    m = nhnet.metrics(est, gt)
    assert m["count"] == 3 and m["invalid"] == 1
    assert m["mean"] == pytest.approx((0 + 7 + 90) / 3, abs=1e-9)
    assert m["rms"] == pytest.approx(math.sqrt((49 + 8100) / 3), abs=1e-9)
    assert m["pgp5"] == pytest.approx(1 / 3) and m["pgp10"] == pytest.approx(2 / 3)
    assert m["over30"] == pytest.approx(1 / 3)
    e = nhnet.angle_errors(est, gt)
    np.testing.assert_allclose(e[:3], [0, 7, 90], atol=1e-9)
    assert np.isnan(e[3])
    with pytest.raises(nhnet.InvalidOptions, match="differ in size"):
        nhnet.metrics(est, gt[:2])


# ---------------------------------------------------------------------------------------------
# Progress, cancellation, GIL


def test_progress_callback_and_cancel():
    pts = sphere(20000)
    seen = []
    nhnet.estimate_normals(pts, method="pca", k=10,
                           progress=lambda f, s: seen.append((f, s)))
    assert seen and seen[-1][0] == pytest.approx(1.0)
    assert all(0.0 <= f <= 1.0 for f, _ in seen)
    with pytest.raises(nhnet.Cancelled):
        nhnet.estimate_normals(pts, progress=lambda f, s: False)

    def boom(f, s):
        raise ZeroDivisionError("from the callback")
    with pytest.raises(ZeroDivisionError, match="from the callback"):
        nhnet.estimate_normals(pts, progress=boom)


def test_gil_released_during_estimation():
    pts = sphere(20000)
    done = threading.Event()
    ticks = 0

    def work():
        nhnet.estimate_normals(pts, method="mfps", threads=1)
        done.set()

    t = threading.Thread(target=work)
    t.start()
    time.sleep(0.05)
    while not done.is_set():
        ticks += 1
    t.join()
    # With the GIL held for the whole call this loop could not run until it ends (0 ticks
    # while the worker computes); released, it spins millions of times during a call that
    # takes seconds. 10000 ticks is far from both.
    assert ticks > 10000


def test_ctrl_c_interrupts_estimation():
    script = (
        "import signal, sys, numpy as np, nhnet\n"
        # Python keeps SIGINT ignored when it starts ignored (a runner launched as a background
        # job of a script): the default handler makes Ctrl-C raise KeyboardInterrupt here.
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "p = np.random.default_rng(0).normal(size=(400000, 3))\n"
        "try:\n"
        "    print('start', flush=True)\n"
        "    nhnet.estimate_normals(p, method='mfps', threads=1)\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted', flush=True); sys.exit(42)\n"
        "print('finished', flush=True)\n")
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True,
                            env=dict(os.environ))
    assert proc.stdout.readline().strip() == "start"
    time.sleep(1.0)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=120)
    assert proc.returncode == 42, out
    assert "interrupted" in out
    # The bridge looks at signals every 50 ms of progress; allow a busy machine 20 s. The whole
    # call (400k points, MFPS, 1 thread) takes over a minute, so a signal only seen when it
    # returns fails this bound.
    assert time.monotonic() - t0 < 20


# ---------------------------------------------------------------------------------------------
# Same normals as nhnet-cli


def test_same_normals_as_cli(tmp_path):
    cloud = nhnet.read(str(SAMPLE))
    sub = tmp_path / "sub.xyz"
    nhnet.write(str(sub), cloud.points[:4000])
    out = tmp_path / "cli.xyzn"
    # --orient none: an array names no sensor, so estimate_normals()'s orient='auto' leaves
    # it unoriented; the CLI's auto orients an .xyz by mst. --method mfps on both: their
    # common default (default_method()) is nhnet where the model is installed.
    subprocess.run([str(CLI), "estimate", str(sub), str(out), "--quiet", "--scales", "30,60",
                    "--seed", "3", "--orient", "none", "--method", "mfps"], check=True)
    cli = nhnet.read(str(out)).normals
    py = nhnet.estimate_normals(nhnet.read(str(sub)).points, method="mfps", scales=[30, 60],
                                seed=3)
    np.testing.assert_allclose(py, cli, atol=1e-12)  # XYZ text keeps full double precision


def test_version_matches_cli_and_cmake():
    cli = subprocess.run([str(CLI), "--version"], capture_output=True, text=True, check=True)
    assert cli.stdout.split() == ["nhnet-cli", nhnet.__version__]
    cmake = (REPO / "CMakeLists.txt").read_text()
    m = re.search(r"project\(nhnet VERSION ([0-9.]+)", cmake)
    assert m and m.group(1) == nhnet.__version__


# ---------------------------------------------------------------------------------------------
# Orientation and denoising (orient.hpp, denoise.hpp)


def test_orient_mst_and_viewpoint_on_a_sphere():
    pts = sphere(3000)
    n = nhnet.estimate_normals(pts, method="pca", k=15)
    o = nhnet.orient(pts, n)  # mst: outward on a closed surface
    assert o.invalid == 0 and o.unoriented == 0 and o.components == 1
    assert np.all(np.sum(o.normals * pts, axis=1) > 0)
    np.testing.assert_array_equal(np.abs(o.normals), np.abs(n))  # signs only, same order
    inward = nhnet.orient(pts, n, "viewpoint", viewpoint=(0.1, 0.0, -0.2))  # inside the sphere
    assert np.all(np.sum(inward.normals * pts, axis=1) < 0)
    keep = nhnet.orient(pts, n, "keep", reference=-pts)
    np.testing.assert_array_equal(keep.normals, inward.normals)
    r = nhnet.estimate(pts, method="pca", k=15, orient="mst")
    np.testing.assert_array_equal(r.normals, o.normals)
    assert r.flipped == o.flipped


def test_orient_errors():
    pts = sphere(100)
    n = nhnet.estimate_normals(pts, method="pca", k=10)
    with pytest.raises(nhnet.InvalidOptions, match="unknown orientation 'sideways'"):
        nhnet.orient(pts, n, "sideways")
    with pytest.raises(nhnet.InvalidOptions, match="needs one reference normal per point"):
        nhnet.orient(pts, n, "keep")
    with pytest.raises(nhnet.InvalidOptions, match="viewpoint is only used with"):
        nhnet.estimate_normals(pts, orient="mst", viewpoint=(0, 0, 0))
    with pytest.raises(nhnet.InvalidOptions, match="viewpoint must be 3 numbers"):
        nhnet.orient(pts, n, "viewpoint", viewpoint=(0, 0))
    with pytest.raises(nhnet.InvalidOptions, match="one row per point"):
        nhnet.orient(pts, n[:50])


def test_denoise_flattens_a_noisy_plane():
    rng = np.random.default_rng(4)
    n_pts = 4000
    pts = np.c_[rng.uniform(0, 1, (n_pts, 2)), rng.normal(scale=0.003, size=n_pts)]
    normals = np.tile([0.0, 0.0, 1.0], (n_pts, 1))
    normals[::2] *= -1  # unoriented input: the update ignores normal signs
    normals[7] = np.nan
    d = nhnet.denoise(pts, normals, threads=2)
    assert d.points.shape == pts.shape
    assert d.skipped == 1 and d.moved + d.isolated == n_pts - 1
    np.testing.assert_array_equal(d.points[7], pts[7])
    # Exact normals of a plane: each step halves a point's offset from its neighbours' mean
    # plane, so after 20 steps |z| is what averaging over overlapping balls leaves of the
    # noise: measured 0.10 of the input's mean |z| (about 13 neighbours a ball); bound 0.5.
    inner = (pts[:, 0] > 0.1) & (pts[:, 0] < 0.9) & (pts[:, 1] > 0.1) & (pts[:, 1] < 0.9)
    assert np.abs(d.points[inner, 2]).mean() < 0.5 * np.abs(pts[inner, 2]).mean()
    # Tangential positions stay (the update moves along the normals).
    np.testing.assert_allclose(d.points[:, :2], pts[:, :2], atol=1e-12)
    assert d.radius > 0 and d.mean_neighbors > 3
    with pytest.raises(nhnet.InvalidOptions):
        nhnet.denoise(pts, normals[:10])


def test_refine_moved_is_the_clis_fast_mode(tmp_path):
    """refine='moved' gives nhnet-cli --refine moved's normals, and differs from the default."""
    pts = np.loadtxt(SAMPLE)[:6000]
    xyz = tmp_path / "part.xyz"
    np.savetxt(xyz, pts)
    out = tmp_path / "moved.xyzn"
    subprocess.run([str(CLI), "estimate", str(xyz), str(out), "--method", "nhnet", "--refine",
                    "moved", "--orient", "none", "--threads", "2"], check=True, capture_output=True)
    cli = np.loadtxt(out)[:, 3:6]
    moved = nhnet.estimate_normals(pts, method="nhnet", refine="moved", orient=None, threads=2)
    default = nhnet.estimate_normals(pts, method="nhnet", orient=None, threads=2)
    # The CLI writes 9 significant digits: 1e-4 deg is far above that rounding, far below any
    # change of method; the default (auto) runs the network on every point of this noisy sample
    # (noise ratio 0.79, far above auto_noise_ratio), so some normals move.
    assert np.nanmax(angles_deg(moved, cli)) < 1e-4
    assert np.nanmax(angles_deg(moved, default)) > 0.1
    with pytest.raises(ValueError, match="refine must be 'all', 'moved' or 'auto'"):
        nhnet.estimate(pts[:100], method="nhnet", refine="some")


def test_estimate_takes_a_model_and_device_like_the_cli(tmp_path):
    """model= / device= as nhnet-cli's --model / --device: another model gives other normals,
    the same model file as $NHNET_MODEL gives the same ones (a child process with the variable
    set), and a missing model or an unknown device is a clear error naming it."""
    pts = np.loadtxt(SAMPLE)[:3000]
    tiny = str(REPO / "tests" / "data" / "nhnet_tiny.pt")
    shipped = nhnet.estimate(pts, method="nhnet", orient=None, threads=2).normals
    mine = nhnet.estimate(pts, method="nhnet", orient=None, threads=2, model=tiny,
                          device="cpu").normals
    cos = np.abs(np.sum(shipped * mine, axis=1)).clip(max=1.0)
    assert float(np.degrees(np.arccos(cos)).max()) > 1.0  # the tiny model is another network
    code = ("import sys, numpy as np, nhnet; p = np.loadtxt(sys.argv[1])[:3000]; "
            "np.save(sys.argv[2], nhnet.estimate(p, method='nhnet', orient=None, threads=2).normals)")
    env = dict(os.environ, NHNET_MODEL=tiny)
    out = tmp_path / "env.npy"
    subprocess.run([sys.executable, "-c", code, str(SAMPLE), str(out)], env=env, check=True)
    assert np.array_equal(np.load(out), mine)  # same model, same threads: same bits
    with pytest.raises(nhnet.InputError, match="nope.pt"):
        nhnet.estimate(pts, method="nhnet", model="nope.pt")
    with pytest.raises(nhnet.InvalidOptions, match="gpu"):
        nhnet.estimate(pts, method="nhnet", device="gpu")


def test_estimate_runs_the_network_in_bfloat16_like_the_cli():
    """precision='bfloat16' as nhnet-cli's --precision: the shipped model's normals move by
    bfloat16's rounding only (8-bit mantissa, ~0.4 % a value; measured on these 3000 points:
    mean 0.29, median 0.19 degree), not by another network's difference (the tiny model's:
    > 1 degree at most points); an unknown precision is a clear error naming it."""
    pts = np.loadtxt(SAMPLE)[:3000]
    f32 = nhnet.estimate(pts, method="nhnet", orient=None, threads=2).normals
    b16 = nhnet.estimate(pts, method="nhnet", orient=None, threads=2, precision="bfloat16").normals
    deg = np.degrees(np.arccos(np.abs(np.sum(f32 * b16, axis=1)).clip(max=1.0)))
    assert 0 < deg.mean() < 2.0
    assert np.median(deg) < 1.0
    with pytest.raises(nhnet.InvalidOptions, match="half"):
        nhnet.estimate(pts, method="nhnet", precision="half")
    # The core's list, default first: what the distributed driver offers as --precision.
    assert nhnet.PRECISIONS == ("auto", "float32", "bfloat16")
