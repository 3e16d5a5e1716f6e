"""Rewrites tests/golden/expected.npz from the current build (only when a change of results is
intended; say why in the commit). Usage, from the repository root after scripts/build.sh:
    PYTHONPATH=build/python python3 tests/golden/make_golden.py
"""

import numpy as np

import golden

if __name__ == "__main__":
    cases = golden.compute()
    np.savez_compressed(golden.EXPECTED, **cases)
    print(f"wrote {len(cases)} arrays to {golden.EXPECTED}")
