"""The normals' confidence (issue 57) through `import nhnet` and `nhnet-cli estimate --confidence`
in every output format, read back with independent readers (laspy, pye57, numpy) where there is
one.

Run: NHNET_BUILD_DIR=$PWD/build PYTHONPATH=build/python /usr/bin/python3 -m pytest \
       tests/python/test_confidence.py -q
"""

import json
import os
import subprocess
from pathlib import Path

import laspy
import numpy as np
import pye57
import pytest

import nhnet

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("NHNET_BUILD_DIR", REPO / "build"))
CLI = BUILD / "cli" / "nhnet-cli"
SAMPLE = REPO / "data" / "sample" / "fandisk_noise0.6.xyz"
N = 4000  # the first sample points: fast, still a CAD part with edges


def cli(*args):
    return subprocess.run([str(CLI), *map(str, args)], capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def cloud(tmp_path_factory):
    d = tmp_path_factory.mktemp("conf")
    pts = np.loadtxt(SAMPLE, max_rows=N)
    src = d / "in.xyz"
    np.savetxt(src, pts, fmt="%.9g")
    r = nhnet.estimate(pts, method="mfps", orient=None, confidence=True)
    return src, pts, r


def test_python_result(cloud):
    _, pts, r = cloud
    c = r.confidence
    assert c.shape == (N,) and c.dtype == np.float64
    ok = r.valid
    assert np.all((c[ok] >= 0) & (c[ok] <= 1)) and np.all(np.isnan(c[~ok]))
    assert np.ptp(c[ok]) > 0.3  # it tells points apart
    assert nhnet.estimate(pts, method="mfps", orient=None).confidence is None
    # the same normals with and without it
    plain = nhnet.estimate(pts, method="mfps", orient=None)
    np.testing.assert_array_equal(plain.normals, r.normals)


def read_ply_property(path, name):
    with open(path, "rb") as f:
        names, count = [], 0
        while (line := f.readline().strip()) != b"end_header":
            w = line.split()
            if w[:2] == [b"element", b"vertex"]:
                count = int(w[2])
            if w[0] == b"property":
                names.append((w[2].decode(), {b"float": "<f4", b"double": "<f8"}[w[1]]))
        rec = np.frombuffer(f.read(), dtype=np.dtype(names), count=count)
    return rec[name].astype(np.float64)


def read_pcd_property(path, name):
    lines = Path(path).read_text().splitlines()
    fields = next(ln for ln in lines if ln.startswith("FIELDS")).split()[1:]
    start = lines.index(next(ln for ln in lines if ln.startswith("DATA"))) + 1
    return np.loadtxt(lines[start:], ndmin=2)[:, fields.index(name)]


# float32 in every format: the written value is the float nearest Python's double.
TOL = 1e-7


def test_cli_writes_it_in_every_format(cloud, tmp_path):
    src, _, r = cloud
    want = r.confidence
    have = r.valid
    for ext in ("ply", "pcd", "xyz", "las", "laz", "e57"):
        out = tmp_path / f"out.{ext}"
        extra = ["--ascii"] if ext == "pcd" else []
        p = cli("estimate", src, out, "--method", "mfps", "--orient", "none", "--confidence",
                "--json", *extra)
        assert p.returncode == 0, p.stderr
        assert json.loads(p.stdout)["low_confidence"] == int((want[have] < 0.5).sum())
        if ext == "ply":
            got = read_ply_property(out, "confidence")
        elif ext == "pcd":
            got = read_pcd_property(out, "confidence")
        elif ext == "xyz":
            got = np.loadtxt(out)[:, 6]
        elif ext in ("las", "laz"):
            las = laspy.read(out)
            assert las.point_format.dimension_by_name("Confidence").dtype == np.float32
            got = np.asarray(las["Confidence"], dtype=np.float64)
        else:
            header = pye57.E57(str(out)).get_header(0)
            assert "nhnet:confidence" in header.point_fields
            continue  # pye57 reads no extension field's values
        np.testing.assert_allclose(got[have], want[have], rtol=0, atol=TOL, err_msg=ext)
        assert np.all(np.isnan(got[~have])), ext


def test_python_write(cloud, tmp_path):
    """nhnet.write(..., confidence=) writes what the CLI writes; a wrong length is refused."""
    _, pts, r = cloud
    out = tmp_path / "py.ply"
    nhnet.write(str(out), pts, r.normals, confidence=r.confidence)
    got = read_ply_property(out, "confidence")
    np.testing.assert_allclose(got[r.valid], r.confidence[r.valid], rtol=0, atol=TOL)
    with pytest.raises(nhnet.InvalidOptions, match="one value per point"):
        nhnet.write(str(tmp_path / "bad.ply"), pts, r.normals, confidence=r.confidence[:-1])
    assert not (tmp_path / "bad.ply").exists()


def test_off_by_default_and_streamed(cloud, tmp_path):
    """Without --confidence no output has the column; with --stream (tiles of 1500 points) the
    streamed PLY and XYZ carry the in-memory confidences: equal to float rounding but for the
    few points whose normal or scoring neighbours move at a tile boundary (test_stream.cpp)."""
    src, _, r = cloud
    out = tmp_path / "plain.ply"
    p = cli("estimate", src, out, "--method", "pca", "--json")
    assert p.returncode == 0 and "low_confidence" not in json.loads(p.stdout)
    assert b"confidence" not in out.read_bytes()[:1000]
    ply, xyz = tmp_path / "s.ply", tmp_path / "s.xyz"
    for o in (ply, xyz):
        p = cli("estimate", src, o, "--stream", "--tile-points", "1500", "--method", "mfps",
                "--orient", "none", "--confidence", "--json")
        assert p.returncode == 0, p.stderr
    got = read_ply_property(ply, "confidence")
    # the report counts the written confidences below 0.5 (nhnet::kLowConfidence)
    assert json.loads(p.stdout)["low_confidence"] == int((got < 0.5).sum())
    text = np.loadtxt(xyz, ndmin=2)
    assert text.shape == (N, 7)
    np.testing.assert_array_equal(text[:, 6].astype(np.float32), got.astype(np.float32))
    ok = r.valid
    assert np.mean(np.abs(got[ok] - r.confidence[ok]) <= 1e-4) > 0.95


def test_las_field_replaced_not_doubled(cloud, tmp_path):
    """Estimating a LAS file that already has a Confidence field (one nhnet wrote) overwrites it in
    place: one field, the new values."""
    src, _, _ = cloud
    first, second = tmp_path / "a.las", tmp_path / "b.las"
    assert cli("estimate", src, first, "--method", "pca", "--orient", "none", "--confidence",
               "--quiet").returncode == 0
    assert cli("estimate", first, second, "--method", "mfps", "--orient", "none",
               "--confidence", "--quiet").returncode == 0
    las = laspy.read(second)
    names = [d.name for d in las.point_format.extra_dimensions]
    assert names.count("Confidence") == 1
    r = nhnet.estimate(np.asarray(laspy.read(first).xyz), method="mfps", orient=None,
                       confidence=True)
    got = np.asarray(las["Confidence"], dtype=np.float64)
    np.testing.assert_allclose(got[r.valid], r.confidence[r.valid], rtol=0, atol=TOL)
