"""LAS / LAZ / E57 through nhnet-cli and `import nhnet`, checked with independent readers and
writers: laspy (+ lazrs for LAZ) and pye57 (scripts/install-deps.sh installs them).

Run: NHNET_BUILD_DIR=$PWD/build PYTHONPATH=build/python /usr/bin/python3 -m pytest \
       tests/python/test_formats_las_e57.py -q
"""

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import laspy
import pye57

import nhnet

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("NHNET_BUILD_DIR", REPO / "build"))
CLI = BUILD / "cli" / "nhnet-cli"

EAST, NORTH, UP = 500000.0, 4000000.0, 100.0


def cli(*args):
    r = subprocess.run([str(CLI), *map(str, args)], capture_output=True, text=True, timeout=300)
    return r


def angles_deg(a, b):
    """Unoriented angle between rows of a and b, degrees."""
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.abs(np.sum(a * b, axis=1)), 0.0, 1.0)))


def terrain(n=1500, seed=1):
    """A gently curved surface, 50 m x 50 m, in local metres."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0, 50, n)
    y = rng.uniform(0, 50, n)
    z = 0.2 * x + 0.1 * y + 2.0 * np.sin(x / 10.0)
    return np.column_stack([x, y, z])


def make_las(path, fmt, version="1.4", n=1500, offset=(EAST, NORTH, UP), extra=False, seed=1):
    """A LAS/LAZ file (by extension) of point format `fmt` with random attributes."""
    rng = np.random.default_rng(seed)
    header = laspy.LasHeader(point_format=fmt, version=version)
    header.scales = [0.001, 0.001, 0.001]
    header.offsets = list(offset)
    if extra:
        header.add_extra_dim(laspy.ExtraBytesParams(name="myextra", type=np.int16))
    las = laspy.LasData(header)
    p = terrain(n, seed)
    las.x, las.y, las.z = p[:, 0] + offset[0], p[:, 1] + offset[1], p[:, 2] + offset[2]
    las.intensity = rng.integers(0, 65535, n)
    las.classification = rng.integers(0, 20, n)
    las.user_data = rng.integers(0, 255, n)
    names = set(las.point_format.dimension_names)
    if "gps_time" in names:
        las.gps_time = rng.uniform(0, 1e6, n)
    if "red" in names:
        las.red, las.green, las.blue = (rng.integers(0, 65535, n) for _ in range(3))
    if "nir" in names:
        las.nir = rng.integers(0, 65535, n)
    if "wavepacket_index" in names:
        las.wavepacket_index = rng.integers(0, 255, n)
        las.return_point_wave_location = rng.uniform(0, 1, n).astype(np.float32)
    if extra:
        las.myextra = rng.integers(-1000, 1000, n)
    las.write(str(path))
    return laspy.read(str(path))


STANDARD = ["X", "Y", "Z", "intensity", "return_number", "number_of_returns", "classification",
            "user_data", "point_source_id"]


def assert_same_attributes(a, b):
    """Every dimension of `a` (laspy) equal in `b`, bit for bit."""
    for name in a.point_format.dimension_names:
        np.testing.assert_array_equal(np.asarray(a[name]), np.asarray(b[name]), err_msg=name)


@pytest.mark.parametrize("fmt", range(11))
def test_las_round_trip_every_point_format(tmp_path, fmt):
    src = tmp_path / f"in{fmt}.las"
    a = make_las(src, fmt, extra=fmt in (3, 7))
    out = tmp_path / "out.las"
    r = cli("estimate", src, out, "--method", "pca")
    assert r.returncode == 0, r.stderr
    b = laspy.read(str(out))
    assert b.header.point_format.id == fmt
    assert len(b.points) == len(a.points)
    assert_same_attributes(a, b)
    # Georeferenced coordinates: the raw integers are the input's, so x y z are exact.
    np.testing.assert_array_equal(np.asarray(b.X), np.asarray(a.X))
    np.testing.assert_array_equal(b.header.offsets, a.header.offsets)
    np.testing.assert_array_equal(b.header.scales, a.header.scales)
    # Normals added as float32 extra bytes; the terrain's slope is at most 0.6 (31 degrees), so
    # every normal is within 31 degrees of vertical (|nz| > cos 31 = 0.857; 0.85 with noise).
    n = np.column_stack([b["NormalX"], b["NormalY"], b["NormalZ"]])
    assert b["NormalX"].dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)
    assert (np.abs(n[:, 2]) > 0.85).all()


def test_las_header_versions_read(tmp_path):
    for version, fmt in [("1.2", 0), ("1.2", 3), ("1.3", 1), ("1.4", 6)]:
        src = tmp_path / f"v{version}_{fmt}.las"
        a = make_las(src, fmt, version=version)
        c = nhnet.read(str(src))
        np.testing.assert_array_equal(c.points[:, 0], np.asarray(a.x))
        np.testing.assert_array_equal(c.extras["intensity"], np.asarray(a.intensity))
        np.testing.assert_array_equal(c.extras["classification"], np.asarray(a.classification))


@pytest.mark.parametrize("fmt", [1, 3, 6, 7, 8])
def test_laz_read_and_written(tmp_path, fmt):
    src = tmp_path / "in.laz"
    a = make_las(src, fmt, extra=fmt == 7)
    out = tmp_path / "out.laz"
    r = cli("estimate", src, out, "--method", "pca")
    assert r.returncode == 0, r.stderr
    b = laspy.read(str(out))  # lazrs decompresses what the laz crate wrote
    assert b.header.are_points_compressed
    assert_same_attributes(a, b)
    assert "NormalX" in b.point_format.dimension_names
    # And back through our reader: LAZ -> LAS keeps the normals as input normals.
    c = nhnet.read(str(out))
    np.testing.assert_array_equal(c.normals[:, 0], np.asarray(b["NormalX"], dtype=np.float64))


def test_las_normals_read_as_input_normals_and_ply_out(tmp_path):
    src = tmp_path / "in.las"
    make_las(src, 3)
    with_normals = tmp_path / "n.las"
    assert cli("estimate", src, with_normals, "--method", "pca").returncode == 0
    c = nhnet.read(str(with_normals))
    assert c.normals is not None
    out = tmp_path / "out.ply"
    r = cli("estimate", with_normals, out, "--method", "pca")
    assert r.returncode == 0, r.stderr
    d = nhnet.read(str(out))
    np.testing.assert_allclose(d.points, c.points, rtol=0, atol=1e-9)
    assert "intensity" in d.extras and "gps_time" in d.extras


def test_ply_to_las_and_laz(tmp_path):
    rng = np.random.default_rng(4)
    pts = terrain(2000) * 0.02  # a small object: 1 m x 1 m
    ply = tmp_path / "in.ply"
    nhnet.write(str(ply), pts, extras={"intensity": rng.integers(0, 60000, 2000).astype(np.uint16),
                                       "quality": rng.uniform(0, 1, 2000).astype(np.float32)})
    for name in ["out.las", "out.laz"]:
        out = tmp_path / name
        r = cli("estimate", ply, out, "--method", "pca")
        assert r.returncode == 0, r.stderr
        b = laspy.read(str(out))
        assert b.header.point_format.id == 6
        # The chosen scale keeps the coordinates to better than 1e-6 of the 1 m object.
        np.testing.assert_allclose(np.column_stack([b.x, b.y, b.z]), pts, rtol=0, atol=1e-6)
        np.testing.assert_array_equal(np.asarray(b.intensity),
                                      nhnet.read(str(ply)).extras["intensity"])
        np.testing.assert_allclose(np.asarray(b["quality"]),
                                   nhnet.read(str(ply)).extras["quality"], rtol=0, atol=0)
        n = np.column_stack([b["NormalX"], b["NormalY"], b["NormalZ"]])
        np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)


def test_georeferenced_normals_equal_local_ones(tmp_path):
    # The same terrain at 500 km easting and at the origin: the estimator works in double, so the
    # normals agree far below 0.5 degree (the bar of the issue; float would lose ~0.06 m here).
    far, near = tmp_path / "far.las", tmp_path / "near.las"
    make_las(far, 6, offset=(EAST, NORTH, UP))
    make_las(near, 6, offset=(0.0, 0.0, 0.0))
    for src in (far, near):
        r = cli("estimate", src, src.with_suffix(".ply"), "--method", "mfps")
        assert r.returncode == 0, r.stderr
    a = nhnet.read(str(far.with_suffix(".ply"))).normals
    b = nhnet.read(str(near.with_suffix(".ply"))).normals
    assert angles_deg(a, b).max() < 0.5


def make_e57(path, scans):
    """scans: list of (name, local points, rotation quaternion wxyz, translation)."""
    e = pye57.E57(str(path), mode="w")
    for name, p, q, t in scans:
        data = {"cartesianX": p[:, 0].copy(), "cartesianY": p[:, 1].copy(),
                "cartesianZ": p[:, 2].copy(),
                "intensity": np.linspace(0, 1, len(p))}
        e.write_scan_raw(data, name=name, rotation=np.array(q, dtype=float),
                         translation=np.array(t, dtype=float))
    e.close()


def quat_z(deg):
    h = np.radians(deg) / 2
    return [np.cos(h), 0.0, 0.0, np.sin(h)]


def rot_z(deg):
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_e57_two_scans_poses_applied(tmp_path):
    rng = np.random.default_rng(5)
    a = rng.normal(size=(800, 3))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = terrain(600) * 0.1
    path = tmp_path / "two.e57"
    make_e57(path, [("left", a, quat_z(90), [10, 0, 0]), ("right", b, quat_z(-30), [0, 5, 1])])
    c = nhnet.read(str(path))
    assert len(c) == 1400
    np.testing.assert_allclose(c.points[:800], a @ rot_z(90).T + [10, 0, 0], atol=1e-9)
    np.testing.assert_allclose(c.points[800:], b @ rot_z(-30).T + [0, 5, 1], atol=1e-9)
    # Same through the CLI, then back out as E57: one scan per sensor, poses kept.
    out = tmp_path / "out.e57"
    r = cli("estimate", path, out, "--method", "pca")
    assert r.returncode == 0, r.stderr
    e = pye57.E57(str(out))
    assert e.scan_count == 2
    h0 = e.get_header(0)
    np.testing.assert_allclose(h0.translation, [10, 0, 0], atol=1e-12)
    np.testing.assert_allclose(np.abs(h0.rotation), np.abs(quat_z(90)), atol=1e-12)
    d0 = e.read_scan(0, ignore_missing_fields=True, transform=True)
    np.testing.assert_allclose(np.column_stack([d0["cartesianX"], d0["cartesianY"],
                                                d0["cartesianZ"]]), c.points[:800], atol=1e-9)
    back = nhnet.read(str(out))
    assert back.normals is not None
    np.testing.assert_allclose(back.points, c.points, atol=1e-9)
    # Normals of the unit sphere (scan 0) are radial about its centre (10, 0, 0).
    radial = back.points[:800] - [10, 0, 0]
    assert np.percentile(angles_deg(back.normals[:800], radial), 90) < 5


def test_e57_bad_pose_refused(tmp_path):
    path = tmp_path / "bad.e57"
    make_e57(path, [("tilted", terrain(100), [2.0, 0, 0, 0], [0, 0, 0])])
    r = cli("estimate", path, tmp_path / "o.ply", "--method", "pca")
    assert r.returncode == 3
    assert "bad.e57" in r.stderr and "not a rotation" in r.stderr
    assert not (tmp_path / "o.ply").exists()
