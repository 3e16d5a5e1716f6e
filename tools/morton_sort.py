#!/usr/bin/env python3
"""A text cloud's rows sorted along a Morton (Z-order) curve, as a scanner's file keeps near
points near each other (issue 23: whole-process timings on shuffled and on ordered files).

    /usr/bin/python3 tools/morton_sort.py IN.xyz[n] OUT.xyz[n]

Reads whitespace-separated rows (the first three columns are x y z; the others travel with
them), orders them by the Morton code of their cell in a grid of cubic cells, 1024 along the bounding
box's longest side (ties in input order), and writes them with 7 decimals.
"""

from __future__ import annotations

import sys

import numpy as np


def spread(v: np.ndarray) -> np.ndarray:
    """The 10 low bits of v moved to every third bit."""
    v = v.astype(np.uint64) & 0x3FF
    v = (v | (v << 16)) & 0x30000FF
    v = (v | (v << 8)) & 0x300F00F
    v = (v | (v << 4)) & 0x30C30C3
    return (v | (v << 2)) & 0x9249249


def morton_order(xyz: np.ndarray) -> np.ndarray:
    lo = xyz.min(axis=0)
    unit = (xyz - lo) / max(float((xyz.max(axis=0) - lo).max()), 1e-300)  # cubic cells
    cell = np.minimum((unit * 1023).astype(np.uint64), 1023)
    code = spread(cell[:, 0]) | (spread(cell[:, 1]) << 1) | (spread(cell[:, 2]) << 2)
    return np.argsort(code, kind="stable")


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        raise SystemExit(__doc__.split("\n\n")[1])
    rows = np.loadtxt(argv[0], ndmin=2)
    if rows.shape[1] < 3:
        raise SystemExit(f"{argv[0]}: expected at least 3 columns (x y z), got {rows.shape[1]}")
    np.savetxt(argv[1], rows[morton_order(rows[:, :3])], fmt="%.7f")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
