"""Golden test (issue 26): every method and front end on fixed clouds against the checked-in
outputs of tests/golden/expected.npz (see tests/golden/golden.py for the cases).

Tolerance: 1e-6 absolute on unit normals (~6e-5 degrees) and on coordinates of a cloud of unit
size. Outputs are float32 in PLY files (one ulp ~6e-8 at 1), so the bound allows a changed
floating-point summation order in a refactor while any real change of a result (a different
neighbour, a sign, a stage skipped) moves values by orders of magnitude more. NaN rows must
stay NaN in the same places.

Cases that run the network (names with "nhnet" or "default") allow 1e-5 (~6e-4 degrees):
libtorch's oneDNN kernels choose their vector width at run time, and the expected outputs made
on an AVX-512 host differ by up to 1.02e-6 on an AVX2-only host (measured 2026-12-04, every
other case within 1e-6 there). A changed neighbour or sign still moves values by far more.
"""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "golden"))
import golden  # noqa: E402

TOLERANCE = 1e-6
NETWORK_TOLERANCE = 1e-5


def tolerance(name):
    return NETWORK_TOLERANCE if "nhnet" in name or "default" in name else TOLERANCE


@pytest.fixture(scope="module")
def results():
    return golden.compute()


@pytest.fixture(scope="module")
def expected():
    with np.load(golden.EXPECTED) as f:
        return {k: f[k] for k in f.files}


def test_same_cases(results, expected):
    assert sorted(results) == sorted(expected)


@pytest.mark.parametrize("name", sorted(np.load(golden.EXPECTED).files))
def test_case_matches(results, expected, name):
    got, want = np.asarray(results[name], dtype=np.float64), expected[name].astype(np.float64)
    assert got.shape == want.shape, name
    assert np.array_equal(np.isnan(got), np.isnan(want)), f"{name}: NaN rows moved"
    finite = ~np.isnan(want)
    diff = np.abs(got[finite] - want[finite])
    worst = float(diff.max()) if diff.size else 0.0
    assert worst <= tolerance(name), f"{name}: largest difference {worst:.3g} > {tolerance(name)}"
