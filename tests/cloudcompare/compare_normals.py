#!/usr/bin/python3
"""Per-point unoriented angle between the normals of two clouds with the same points in the same
order (PLY, binary or ASCII, vertex element with scalar properties; or .xyzn text: x y z nx ny nz).

    compare_normals.py A B [--signed] [--max-deg D] [--mean-deg M] [--max-offset O] [--min-valid F]
                       [--scalar NAME_A NAME_B [--floor F] [--max-abs E]]

Angles are unoriented (acos |a.b|) unless --signed (acos a.b: over 90 means opposite signs).
Prints count, mean, p99, max (degrees) and the largest point offset; exits 1 when a bound is
exceeded, 2 on unreadable input. Zero or NaN normals in A count as invalid (CloudCompare stores a
failed point's normal as zero); --min-valid is the share of points that must be valid in A.
--scalar also compares a per-point property of A (PLY) with one of B (PLY, or the 7th column of
an .xyz): max(B, F) against A where B is finite (the points that have a normal), at most E apart.
"""
import argparse
import sys

import numpy as np

PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
    "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


def read_columns(path):
    """The vertex properties of a PLY file: {name: float64 array}."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"ply":
            raise ValueError(f"{path}: not a PLY file")
        fmt, count, props, in_vertex = None, 0, [], False
        while True:
            line = f.readline()
            if not line:
                raise ValueError(f"{path}: no end_header")
            words = line.decode("ascii", "replace").split()
            if not words:
                continue
            if words[0] == "format":
                fmt = words[1]
            elif words[0] == "element":
                in_vertex = words[1] == "vertex"
                if in_vertex:
                    count = int(words[2])
                elif not count:
                    raise ValueError(f"{path}: an element before the vertices")
            elif words[0] == "property" and in_vertex:
                if words[1] == "list":
                    raise ValueError(f"{path}: list property in the vertex element")
                props.append((words[2], PLY_TYPES[words[1]]))
            elif words[0] == "end_header":
                break
        if fmt == "ascii":
            data = np.loadtxt(f, max_rows=count, ndmin=2)[:, : len(props)]
            cols = {name: data[:, i] for i, (name, _) in enumerate(props)}
        else:
            endian = "<" if fmt == "binary_little_endian" else ">"
            dtype = np.dtype([(n, endian + t) for n, t in props])
            rec = np.frombuffer(f.read(dtype.itemsize * count), dtype=dtype, count=count)
            cols = {name: rec[name].astype(np.float64) for name, _ in props}
    return cols


def read_ply(path):
    cols = read_columns(path)
    pts = np.stack([cols["x"], cols["y"], cols["z"]], axis=1)
    nrm = np.stack([cols["nx"], cols["ny"], cols["nz"]], axis=1)
    return pts, nrm


def read(path):
    if path.endswith(".ply"):
        return read_ply(path)
    data = np.loadtxt(path, ndmin=2)
    return data[:, 0:3], data[:, 3:6]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--signed", action="store_true", help="oriented angles (acos a.b)")
    ap.add_argument("--max-deg", type=float)
    ap.add_argument("--mean-deg", type=float)
    ap.add_argument("--max-offset", type=float, default=1e-5,
                    help="largest allowed point distance relative to the bbox diagonal")
    ap.add_argument("--min-valid", type=float, default=0.999)
    ap.add_argument("--scalar", nargs=2, metavar=("NAME_A", "NAME_B"))
    ap.add_argument("--floor", type=float, default=-np.inf)
    ap.add_argument("--max-abs", type=float, default=0.0)
    args = ap.parse_args()
    try:
        pa, na = read(args.a)
        pb, nb = read(args.b)
    except (OSError, ValueError, KeyError) as e:
        print(f"compare_normals: {e}", file=sys.stderr)
        return 2
    if len(pa) != len(pb):
        print(f"compare_normals: {len(pa)} vs {len(pb)} points", file=sys.stderr)
        return 1
    diag = np.linalg.norm(pa.max(0) - pa.min(0))
    offset = np.linalg.norm(pa - pb, axis=1).max() / diag
    la, lb = np.linalg.norm(na, axis=1), np.linalg.norm(nb, axis=1)
    valid = np.isfinite(la) & np.isfinite(lb) & (la > 0.5) & (lb > 0.5)
    dot = (na[valid] * nb[valid]).sum(1) / (la[valid] * lb[valid])
    cos = dot if args.signed else np.abs(dot)
    deg = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    share = valid.mean()
    print(f"count {valid.sum()} valid_share {share:.4f} mean_deg {deg.mean():.4f} "
          f"p99_deg {np.percentile(deg, 99):.4f} max_deg {deg.max():.4f} offset {offset:.2e}")
    ok = offset <= args.max_offset and share >= args.min_valid
    if args.max_deg is not None:
        ok = ok and deg.max() <= args.max_deg
    if args.mean_deg is not None:
        ok = ok and deg.mean() <= args.mean_deg
    if args.scalar:
        ok = compare_scalar(args) and ok
    return 0 if ok else 1


def compare_scalar(args):
    """--scalar: A's property against max(B's, floor) where B's is finite."""
    a = read_columns(args.a)[args.scalar[0]]
    b = (read_columns(args.b)[args.scalar[1]] if args.b.endswith(".ply")
         else np.loadtxt(args.b, ndmin=2)[:, 6])
    have = np.isfinite(b)
    diff = np.abs(a[have] - np.maximum(b[have], args.floor))
    print(f"{args.scalar[0]} vs {args.scalar[1]}: {have.sum()} values, max |diff| {diff.max():.2e}, "
          f"range {b[have].min():.3f}-{b[have].max():.3f}")
    # a constant field would pass a copy of anything constant: the values must spread
    return bool(have.sum() > 0 and diff.max() <= args.max_abs and np.ptp(b[have]) > 0.1)


if __name__ == "__main__":
    sys.exit(main())
