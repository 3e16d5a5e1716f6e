"""Tests of the benchmark/training data generator (nhnet_training.datagen / .meshes)."""

import filecmp
import json
from pathlib import Path

import numpy as np
import pytest

from nhnet_training import datagen, meshes

needs_cgal = pytest.mark.skipif(not meshes.CGAL_DATA_TARBALL.exists(),
                                reason="libcgal-demo not installed")

OFF_QUAD = """# a hand-written OFF file
OFF   # keyword with a trailing comment
# counts come next
5 3 0

0 0 0   # v0
1 0 0
1 1 0
0 1 0
0.5 0.5 1
4 0 1 2 3      # a quad, fan-triangulated
3 0 1 4  255 0 0   # triangle with a face colour
2 1 2              # a segment: dropped
"""


def test_off_parser_quad_comments_and_colours():
    v, f = meshes.parse_off(OFF_QUAD)
    assert v.shape == (5, 3)
    np.testing.assert_array_equal(v[4], [0.5, 0.5, 1.0])
    # quad -> (0,1,2), (0,2,3); then the triangle; the 2-gon is dropped
    assert sorted(map(tuple, f.tolist())) == sorted([(0, 1, 2), (0, 2, 3), (0, 1, 4)])


def test_off_parser_variants():
    coff = "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2\n"
    v, f = meshes.parse_off(coff)
    assert v.shape == (3, 3) and f.tolist() == [[0, 1, 2]]
    noff = "NOFF 3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n"
    v, f = meshes.parse_off(noff)
    np.testing.assert_array_equal(v, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    pent = "OFF\n5 1 0\n0 0 0\n1 0 0\n2 1 0\n1 2 0\n0 1 0\n5 0 1 2 3 4\n"
    v, f = meshes.parse_off(pent)
    assert f.tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4]]
    with pytest.raises(meshes.MeshFormatError):
        meshes.parse_off("PLY\n1 2 3\n")
    with pytest.raises(meshes.MeshFormatError):
        meshes.parse_off("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")


def test_ply_reader_ascii_and_binary(tmp_path):
    verts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float32)
    head = ("ply\nformat {}\nelement vertex 4\nproperty float x\nproperty float y\n"
            "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
            "end_header\n")
    a = tmp_path / "a.ply"
    a.write_text(head.format("ascii 1.0") + "".join("%g %g %g\n" % tuple(p) for p in verts)
                 + "4 0 1 2 3\n")
    b = tmp_path / "b.ply"
    b.write_bytes(head.format("binary_little_endian 1.0").encode() + verts.tobytes()
                  + bytes([4]) + np.array([0, 1, 2, 3], "<i4").tobytes())
    for p in (a, b):
        v, f = meshes.read_mesh(p)
        np.testing.assert_array_equal(v, verts)
        assert f.tolist() == [[0, 1, 2], [0, 2, 3]]


def test_degenerate_faces_rejected():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], dtype=float)
    f = np.array([[0, 1, 2], [0, 1, 3], [1, 1, 2]])  # collinear, repeated vertex
    assert datagen.valid_faces(v, f).tolist() == [0]
    p, n, fid = datagen.sample_surface(v, f, 1000, np.random.default_rng(0))
    assert (fid == 0).all()
    np.testing.assert_allclose(n, np.tile([0, 0, 1.0], (1000, 1)))


def test_stable_seed_is_not_python_hash():
    # fixed value: crc32 is stable across processes and Python versions
    assert datagen.stable_seed("noise", "fandisk", 0.6, "uniform", base=0) == \
        __import__("zlib").crc32(b"noise|fandisk|0.6|uniform")
    assert datagen.stable_seed("a", base=1) != datagen.stable_seed("b", base=1)


@needs_cgal
def test_cube_normals_axis_aligned_and_points_on_faces():
    v, f = meshes.load_model("cube")
    p, n, fid = datagen.sample_surface(v, f, 5000, np.random.default_rng(1))
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12)
    # every normal is +-e_x, +-e_y or +-e_z
    np.testing.assert_allclose(np.sort(np.abs(n), axis=1), np.tile([0, 0, 1.0], (5000, 1)),
                               atol=1e-12)
    # points lie on the plane of their face, and cover all 6 sides
    a = v[f[fid, 0]]
    np.testing.assert_allclose(np.einsum("ij,ij->i", p - a, n), 0.0, atol=1e-9)
    assert len({tuple(np.round(x).astype(int)) for x in n}) == 6


@needs_cgal
def test_gt_normals_unit_and_orthogonal_to_their_face():
    v, f = meshes.load_model("fandisk")
    p, n, fid = datagen.sample_clean("fandisk", "uniform", 20000)[:3]
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12)
    tri = v[f[fid]]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    for e in (e1, e2):
        cos = np.einsum("ij,ij->i", e, n) / np.linalg.norm(e, axis=1)
        assert np.abs(cos).max() < 1e-9
    # the point is inside its triangle (barycentric coordinates in [0, 1])
    d = p - tri[:, 0]
    m = np.stack([e1, e2, n], axis=2)
    bc = np.linalg.solve(m, d[:, :, None])[:, :, 0]
    assert (bc[:, :2] > -1e-9).all() and (bc[:, :2].sum(1) < 1 + 1e-9).all()
    assert np.abs(bc[:, 2]).max() < 1e-9


@needs_cgal
@pytest.mark.parametrize("level", [0.125, 0.6, 1.2])
def test_noise_std_matches_level(level):
    clean = datagen.sample_clean("rotor", "uniform", 30000)[0]
    seed = datagen.stable_seed("noise", "rotor", level, "uniform")
    noisy, std = datagen.add_noise(clean, level, seed)
    expected = level / 100 * datagen.bbox_diagonal(clean)
    assert std == pytest.approx(expected, rel=1e-12)
    measured = (noisy - clean).std()
    assert abs(measured / expected - 1) < 0.05
    # per coordinate as well
    for k in range(3):
        assert abs((noisy - clean)[:, k].std() / expected - 1) < 0.05
    zero, s0 = datagen.add_noise(clean, 0.0, seed)
    assert s0 == 0.0 and np.array_equal(zero, clean)


@needs_cgal
def test_density_variants():
    n = 20000
    p, _, _, _ = datagen.sample_clean("part", "gradient", n)
    u, _, _, _ = datagen.sample_clean("part", "uniform", n)
    assert p.shape == (n, 3)
    lo, hi = u[:, 0].min(), u[:, 0].max()
    mid = (lo + hi) / 2
    # gradient: keep probability falls along x -> relatively fewer points on the high-x half
    frac_u = (u[:, 0] > mid).mean()
    frac_g = (p[:, 0] > mid).mean()
    assert frac_g < 0.8 * frac_u
    s, _, _, _ = datagen.sample_clean("part", "stripes", n)
    assert s.shape == (n, 3)


def test_splits_disjoint_and_no_test_only_in_train():
    train, bench = set(datagen.TRAIN_MODELS), set(datagen.BENCHMARK_MODELS)
    assert not train & bench
    assert not train & set(datagen.NEAR_DUPLICATES)
    assert not [m for m in train if meshes.is_test_only(m)]
    for prefix in ("fandisk", "armadillo", "bunny", "cube"):
        assert meshes.is_test_only(prefix + "_x") and meshes.is_test_only(prefix.upper())
    assert len(bench) == 35
    # Issue 23: at least as many organic training shapes as CAD ones, together all the models.
    assert len(datagen.TRAIN_ORGANIC) >= len(datagen.TRAIN_CAD) == 16
    assert datagen.TRAIN_MODELS == datagen.TRAIN_CAD + datagen.TRAIN_ORGANIC
    for subset in (False, True):
        planned = {j.model for j in datagen.plan_train(100, subset)}
        assert planned and not planned & bench
        assert not [m for m in planned if meshes.is_test_only(m)]
    # the benchmark categories use the protocol's noise levels
    cats = datagen.BENCHMARK_CATEGORIES
    assert cats["SharpFeature"][1] == [0.05, 0.1, 0.15]
    assert cats["RichFeature"][1] == [0.05, 0.1, 0.15, 0.2]
    assert cats["SmoothSurface"][1] == [0.05, 0.1, 0.15]
    assert cats["BigNoise"][1] == [0.2, 0.3, 0.4, 0.5]
    assert datagen.PCPNET_LEVELS == [0.0, 0.125, 0.6, 1.2]


@needs_cgal
def test_models_exist_in_tarball():
    have = set(meshes.available_models())
    missing = [m for m in datagen.BENCHMARK_MODELS + datagen.TRAIN_MODELS if m not in have]
    assert not missing


def _files(d: Path):
    return sorted(p.relative_to(d) for p in d.rglob("*") if p.is_file())


@needs_cgal
def test_generation_is_deterministic_and_complete(tmp_path):
    args = ["--set", "benchmark", "--subset", "--points", "1500",
            "--categories", "SharpFeature,PCPNetNoise,PCPNetDensity"]
    assert datagen.main(["--out", str(tmp_path / "a"), "--jobs", "2"] + args) == 0
    assert datagen.main(["--out", str(tmp_path / "b"), "--jobs", "1"] + args) == 0
    a, b = tmp_path / "a" / "benchmark", tmp_path / "b" / "benchmark"
    fa = _files(a)
    assert fa == _files(b)
    _, mismatch, errors = filecmp.cmpfiles(a, b, [str(x) for x in fa], shallow=False)
    assert not mismatch and not errors

    index = json.loads((a / "index.json").read_text())
    clouds = index["clouds"]
    # 2 SharpFeature models x 3 levels + their PCPNet levels (4) + density variants (2)
    # for the 8 subset models (2 per category)
    assert len([c for c in clouds if c["category"] == "SharpFeature"]) == 6
    assert len([c for c in clouds if c["category"] == "PCPNetNoise"]) == 8 * 4
    assert len([c for c in clouds if c["category"] == "PCPNetDensity"]) == 8 * 2
    c = next(c for c in clouds if c["name"] == "fandisk_noise0.1")
    assert c["category"] == "SharpFeature" and c["noise_percent"] == 0.1
    stem = a / "SharpFeature" / "fandisk_noise0.1"
    xyz = np.loadtxt(f"{stem}.xyz")
    nrm = np.loadtxt(f"{stem}.normals")
    clean = np.loadtxt(f"{stem}.clean.xyz")
    xyzn = np.loadtxt(f"{stem}.gt.xyzn")
    assert xyz.shape == nrm.shape == clean.shape == (1500, 3) and c["points"] == 1500
    np.testing.assert_array_equal(xyzn, np.hstack([xyz, nrm]))
    np.testing.assert_allclose(np.linalg.norm(nrm, axis=1), 1, atol=1e-8)
    assert c["bbox_diagonal"] == pytest.approx(datagen.bbox_diagonal(clean), rel=1e-6)
    assert np.abs(xyz - clean).max() > 0
    # same model, another level: same clean points, different noise
    clean2 = np.loadtxt(a / "SharpFeature" / "fandisk_noise0.05.clean.xyz")
    np.testing.assert_array_equal(clean, clean2)
    # noise-free PCPNet level: noisy == clean
    z = a / "PCPNetNoise" / "fandisk_noise0"
    np.testing.assert_array_equal(np.loadtxt(f"{z}.xyz"), np.loadtxt(f"{z}.clean.xyz"))

    # another base seed gives other clouds
    datagen.main(["--out", str(tmp_path / "c"), "--seed", "7", "--jobs", "1"] + args)
    assert (tmp_path / "c" / "benchmark" / "SharpFeature" / "fandisk_noise0.1.xyz"
            ).read_bytes() != (stem.parent / "fandisk_noise0.1.xyz").read_bytes()


@needs_cgal
def test_sample_set(tmp_path):
    datagen.main(["--out", str(tmp_path), "--set", "sample", "--points", "2000"])
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["fandisk_noise0.6.clean.xyz", "fandisk_noise0.6.gt.xyzn", "fandisk_noise0.6.xyz",
                     "index.json"]
    assert np.loadtxt(tmp_path / "fandisk_noise0.6.gt.xyzn").shape == (2000, 6)


@needs_cgal
def test_train_subset_layout(tmp_path, capsys):
    assert datagen.main(["--list"]) == 0
    assert "SharpFeature" in capsys.readouterr().out
    datagen.main(["--out", str(tmp_path), "--set", "train", "--subset", "--points", "500",
                  "--jobs", "1"])
    index = json.loads((tmp_path / "train" / "index.json").read_text())
    models = {c["model"] for c in index["clouds"]}
    assert models and not models & set(datagen.BENCHMARK_MODELS)
    assert not any(c["test_only"] for c in index["clouds"])
    for c in index["clouds"]:
        for f in c["files"]:
            assert (tmp_path / "train" / f).is_file()
    levels = {c["noise_percent"] for c in index["clouds"] if c["variant"] == "uniform"}
    assert levels == set(datagen.TRAIN_LEVELS)


@needs_cgal
def test_models_filter(tmp_path):
    # --models keeps only the named benchmark models (the benchmark's quick mode relies on it)
    assert datagen.main(["--out", str(tmp_path), "--points", "500", "--jobs", "1",
                         "--models", "fandisk,bunny00",
                         "--categories", "SharpFeature,SmoothSurface,BigNoise"]) == 0
    index = json.loads((tmp_path / "benchmark" / "index.json").read_text())
    got = {(c["category"], c["model"]) for c in index["clouds"]}
    assert got == {("SharpFeature", "fandisk"), ("SmoothSurface", "bunny00")}
    assert len(index["clouds"]) == 3 + 3
    with pytest.raises(SystemExit):
        datagen.main(["--out", str(tmp_path), "--models", "not-a-model"])
