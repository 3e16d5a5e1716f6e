"""tools/stage_timing.py --cli: a whole nhnet-cli process split by the stage names of its
progress bar (drawn on a pseudo-terminal), streamed tiles summed per stage."""
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("NHNET_BUILD_DIR", REPO / "build"))


def stages(cloud, *extra):
    """The tool's total and stage seconds, and the wall seconds of the tool's own process."""
    start = time.perf_counter()
    out = subprocess.run([sys.executable, str(REPO / "tools" / "stage_timing.py"), str(cloud),
                          "--cli", str(BUILD / "cli" / "nhnet-cli"), "--method", "pca",
                          "--threads", "2", *extra], capture_output=True, text=True, check=True)
    wall = time.perf_counter() - start
    lines = out.stdout.strip().splitlines()
    total = float(lines[0].split()[1])
    rows = {line[:24].strip(): float(line[24:]) for line in lines[1:]}
    return total, rows, wall


def test_cli_stages_of_a_streamed_run(tmp_path):
    rng = np.random.default_rng(3)
    p = rng.normal(size=(60000, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    cloud = tmp_path / "sphere.xyz"
    np.savetxt(cloud, p, fmt="%.6f")
    total, rows, wall = stages(cloud)
    # The in-memory run's own stages, named as its bar names them; together they cover the
    # nhnet-cli process, most of the tool's own wall time (the rest: Python's start-up).
    assert {"start", "reading", "neighbours", "pca"} <= set(rows), rows
    assert 0.5 * wall < total <= wall, (total, wall)
    # Streamed in tiles: the passes only a stream has.
    _, streamed, _ = stages(cloud, "--", "--stream", "--tile-points", "20000")
    assert {"binning", "noise probe", "neighbours"} <= set(streamed) and "binning" not in rows
