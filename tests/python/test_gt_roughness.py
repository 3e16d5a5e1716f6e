"""tools/gt_roughness.py (issue 23): the floor measures how far true normals turn within a point
spacing, not how rough a surface is at large: zero on a plane, large where the faces are smaller
than the spacing, small again where each face spans many spacings."""
import json
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tools"))
sys.path.insert(0, str(REPO / "training"))
import gt_roughness as gr  # noqa: E402
from nhnet_training.datagen import sample_surface  # noqa: E402


def grid_mesh(cells: int, bump: float, seed: int = 0):
    """The unit square as cells x cells x 2 triangles, each vertex raised by bump * N(0, 1)."""
    t = np.linspace(0.0, 1.0, cells + 1)
    x, y = np.meshgrid(t, t, indexing="ij")
    z = bump * np.random.default_rng(seed).normal(size=x.shape)
    v = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    i = np.arange(cells)[:, None] * (cells + 1) + np.arange(cells)[None, :]
    a, b, c, d = i.ravel(), i.ravel() + cells + 1, i.ravel() + 1, i.ravel() + cells + 2
    f = np.concatenate([np.stack([a, b, c], 1), np.stack([c, b, d], 1)])
    return v, f


def floor_of(cells: int, bump: float, points: int = 2000) -> dict:
    mesh = grid_mesh(cells, bump)
    p, n, _ = sample_surface(*mesh, points, np.random.default_rng(1))
    return gr.cloud_floors(p, n, mesh, dense=100_000)


def test_a_plane_has_no_floor():
    f = floor_of(60, 0.0)
    assert f["floor_1"] < 1e-6 and f["floor_2"] < 1e-6


def test_faces_below_the_spacing_make_the_floor():
    # 7 200 faces under 2 000 points (spacing ~0.011, faces 0.017 wide), tilted ~7 degrees RMS
    # (bump 0.002 over a 0.017 edge): most of that tilt is below the spacing, so the floor is
    # several degrees; the same bumps on faces 0.1 wide (10 x 10 cells, ~45 points a face)
    # leave only the creases between faces, under half of it.
    fine = floor_of(60, 0.002)
    coarse = floor_of(10, 0.012)  # the same slopes on the larger faces
    assert fine["floor_1"] > 3.0
    assert coarse["floor_1"] < 0.5 * fine["floor_1"]
    assert fine["floor_2"] >= fine["floor_1"]  # a wider mean departs further


def test_report_splits_rms_and_states_what_the_bar_needs(tmp_path, capsys):
    floors = tmp_path / "floors.jsonl"
    recs = tmp_path / "records.jsonl"
    floors.write_text("".join(json.dumps({"cloud": c, "floor_1": 6.0, "floor_2": 8.0}) + "\n"
                              for c in ("a", "b")))
    rows = []
    for c in ("a", "b"):
        rows.append({"cloud": c, "category": "X", "method": "nhnet", "k": 0, "rms_deg": 10.0})
        rows.append({"cloud": c, "category": "X", "method": "pcl-pca", "k": 18, "rms_deg": 12.0})
        rows.append({"cloud": c, "category": "X", "method": "pcl-pca", "k": 50, "rms_deg": 15.0})
    recs.write_text("".join(json.dumps(r) + "\n" for r in rows))
    gr.main(["report", str(floors), str(recs)])
    line = [s for s in capsys.readouterr().out.splitlines() if s.startswith("| X |")][0]
    cells = [s.strip() for s in line.split("|")[1:-1]]
    # rest = sqrt(RMS^2 - floor^2): NH-Net 8.00, PCL (k=18, the better K) sqrt(108) = 10.39
    assert cells[3] == "10.00 / 8.00" and cells[4] == "12.00 / 10.39 (k=18)"
    assert cells[5] == "-23.0 %"
    # bar 9.60 = sqrt(36 + r^2) -> r = 7.49, i.e. 27.9 % below PCL's rest
    assert cells[6] == "9.60"
    assert float(cells[7].split()[0]) == pytest.approx(100 * (np.sqrt(9.6**2 - 36) / np.sqrt(108) - 1),
                                                       abs=0.1)
