"""Mesh access: the CGAL demo meshes Debian ships, and an OFF / PLY reader.

The meshes come from ``libcgal-demo`` (``/usr/share/doc/libcgal-dev/data.tar.gz``,
folder ``data/meshes``).  They are extracted once, with :mod:`tarfile`, into a cache
directory (``$NHNET_CACHE`` or ``$XDG_CACHE_HOME/nhnet`` or ``~/.cache/nhnet``).

Every reader returns ``(vertices float64 (V,3), triangles int64 (F,3))``; polygons are
triangulated as fans around their first vertex.
"""

from __future__ import annotations

import os
import struct
import tarfile
from pathlib import Path

import numpy as np

CGAL_DATA_TARBALL = Path("/usr/share/doc/libcgal-dev/data.tar.gz")
TAR_MESH_DIR = "data/meshes/"

# Any model whose name starts with one of these is test-only: never train or tune on it.
TEST_ONLY_PREFIXES = ("fandisk", "armadillo", "bunny", "cube")


def is_test_only(name: str) -> bool:
    return name.lower().startswith(TEST_ONLY_PREFIXES)


class MeshFormatError(ValueError):
    pass


# ----------------------------------------------------------------------------- OFF

def _strip_comment(line: str) -> str:
    i = line.find("#")
    return line if i < 0 else line[:i]


def _fans_to_triangles(faces: list[list[int]]) -> np.ndarray:
    """Fan-triangulate polygons (lists of vertex ids); polygons with < 3 ids are dropped."""
    tris: list[np.ndarray] = []
    by_len: dict[int, list[list[int]]] = {}
    for f in faces:
        if len(f) >= 3:
            by_len.setdefault(len(f), []).append(f)
    for n, group in sorted(by_len.items()):
        g = np.asarray(group, dtype=np.int64)  # (m, n)
        # triangles (0, k, k+1) for k = 1..n-2, face order kept within each polygon
        k = np.arange(1, n - 1)
        t = np.stack([np.repeat(g[:, :1], n - 2, axis=1), g[:, k], g[:, k + 1]], axis=2)
        tris.append(t.reshape(-1, 3))
    if not tris:
        return np.zeros((0, 3), dtype=np.int64)
    return np.concatenate(tris, axis=0)


def parse_off(text: str) -> tuple[np.ndarray, np.ndarray]:
    """Parse OFF text (OFF, COFF, NOFF, CNOFF, STOFF ...; ``#`` comments; polygons).

    Per-vertex extras (normals, colours, texture coordinates) and per-face colours are
    ignored.  Polygonal faces are triangulated as fans.
    """
    lines = [s.split() for s in (_strip_comment(l) for l in text.splitlines())]
    lines = [t for t in lines if t]
    if not lines:
        raise MeshFormatError("empty OFF file")
    head = lines[0]
    kw = head[0]
    if not kw.endswith("OFF"):
        raise MeshFormatError(f"not an OFF file (first keyword {kw!r})")
    if "4" in kw[:-3] or "n" in kw[:-3]:
        raise MeshFormatError(f"unsupported OFF variant {kw!r} (only 3D)")
    rest = head[1:]
    pos = 1
    if len(rest) < 3:
        rest = rest + lines[pos]
        pos += 1
    try:
        nv, nf = int(rest[0]), int(rest[1])
    except (ValueError, IndexError) as e:
        raise MeshFormatError("bad OFF counts line") from e
    if pos + nv + nf > len(lines):
        raise MeshFormatError(
            f"OFF file truncated: {nv} vertices + {nf} faces announced, "
            f"{len(lines) - pos} lines present")
    try:
        verts = np.array([[float(x) for x in t[:3]] for t in lines[pos:pos + nv]],
                         dtype=np.float64)
    except ValueError as e:
        raise MeshFormatError("bad vertex line") from e
    if verts.shape != (nv, 3):
        raise MeshFormatError("vertex lines need 3 coordinates")
    pos += nv
    faces: list[list[int]] = []
    for t in lines[pos:pos + nf]:
        n = int(t[0])
        if len(t) < n + 1:
            raise MeshFormatError(f"face line too short: {' '.join(t)}")
        faces.append([int(x) for x in t[1:n + 1]])
    tris = _fans_to_triangles(faces)
    if tris.size and (tris.min() < 0 or tris.max() >= nv):
        raise MeshFormatError("face refers to a vertex that does not exist")
    return verts, tris


def read_off(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    with open(path, "r", encoding="latin-1") as f:
        return parse_off(f.read())


# ----------------------------------------------------------------------------- PLY

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


def read_ply(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """Minimal PLY mesh reader (ascii, binary little/big endian): x, y, z + face lists."""
    data = Path(path).read_bytes()
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise MeshFormatError("not a PLY file")
    nl = data.find(b"\n", end)
    header = data[:end].decode("latin-1").splitlines()
    body = data[nl + 1:]
    fmt = None
    elements: list[tuple[str, int, list[tuple]]] = []
    for line in header:
        t = line.split()
        if not t:
            continue
        if t[0] == "format":
            fmt = t[1]
        elif t[0] == "element":
            elements.append((t[1], int(t[2]), []))
        elif t[0] == "property":
            if t[1] == "list":
                elements[-1][2].append(("list", t[4], t[2], t[3]))
            else:
                elements[-1][2].append(("scalar", t[2], t[1]))
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise MeshFormatError(f"unsupported PLY format {fmt!r}")
    verts = np.zeros((0, 3))
    faces: list[list[int]] = []
    if fmt == "ascii":
        toks = body.decode("latin-1").split()
        p = 0
        vl: list[list[float]] = []
        for name, count, props in elements:
            for _ in range(count):
                rec = {}
                for pr in props:
                    if pr[0] == "list":
                        n = int(toks[p]); p += 1
                        rec[pr[1]] = [int(float(x)) for x in toks[p:p + n]]; p += n
                    else:
                        rec[pr[1]] = float(toks[p]); p += 1
                if name == "vertex":
                    vl.append([rec["x"], rec["y"], rec["z"]])
                elif name == "face":
                    faces.append(rec.get("vertex_indices", rec.get("vertex_index", [])))
        verts = np.array(vl, dtype=np.float64).reshape(-1, 3)
    else:
        bo = "<" if fmt == "binary_little_endian" else ">"
        p = 0
        for name, count, props in elements:
            if all(pr[0] == "scalar" for pr in props):
                dt = np.dtype([(pr[1], bo + _PLY_TYPES[pr[2]]) for pr in props])
                arr = np.frombuffer(body, dtype=dt, count=count, offset=p)
                p += dt.itemsize * count
                if name == "vertex":
                    verts = np.stack([arr["x"], arr["y"], arr["z"]], axis=1).astype(np.float64)
            else:
                for _ in range(count):
                    rec = {}
                    for pr in props:
                        if pr[0] == "list":
                            ct = np.dtype(bo + _PLY_TYPES[pr[2]])
                            it = np.dtype(bo + _PLY_TYPES[pr[3]])
                            n = int(np.frombuffer(body, ct, 1, p)[0]); p += ct.itemsize
                            rec[pr[1]] = np.frombuffer(body, it, n, p).tolist()
                            p += it.itemsize * n
                        else:
                            st = np.dtype(bo + _PLY_TYPES[pr[2]])
                            rec[pr[1]] = np.frombuffer(body, st, 1, p)[0]; p += st.itemsize
                    if name == "face":
                        faces.append(rec.get("vertex_indices", rec.get("vertex_index", [])))
    return verts, _fans_to_triangles(faces)


def read_mesh(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    suffix = Path(path).suffix.lower()
    if suffix == ".off":
        return read_off(path)
    if suffix == ".ply":
        return read_ply(path)
    raise MeshFormatError(f"unsupported mesh format {suffix!r}")


# ----------------------------------------------------------------------------- cache

def cache_dir() -> Path:
    env = os.environ.get("NHNET_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "nhnet"


def mesh_dir(tarball: str | os.PathLike = CGAL_DATA_TARBALL) -> Path:
    """Directory holding the extracted CGAL meshes (extracted on first use)."""
    out = cache_dir() / "cgal-meshes"
    stamp = out / ".complete"
    if stamp.exists():
        return out
    tarball = Path(tarball)
    if not tarball.exists():
        raise FileNotFoundError(
            f"{tarball} not found: install Debian's libcgal-demo (apt-get install libcgal-demo)")
    out.mkdir(parents=True, exist_ok=True)
    tmp_suffix = f".tmp{os.getpid()}"
    with tarfile.open(tarball, "r:gz") as tar:
        for m in tar:
            if not m.isfile() or not m.name.startswith(TAR_MESH_DIR):
                continue
            name = m.name[len(TAR_MESH_DIR):]
            if "/" in name or not name.lower().endswith((".off", ".ply")):
                continue
            f = tar.extractfile(m)
            if f is None:
                continue
            tmp = out / (name + tmp_suffix)
            tmp.write_bytes(f.read())
            os.replace(tmp, out / name)  # atomic: concurrent extractions are harmless
    stamp.touch()
    return out


def available_models() -> list[str]:
    d = mesh_dir()
    return sorted(p.stem for p in d.iterdir() if p.suffix.lower() in (".off", ".ply"))


_MESH_CACHE: dict[str, tuple[np.ndarray, np.ndarray]] = {}


def load_model(name: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of a CGAL demo model by name (e.g. ``"fandisk"``)."""
    if name not in _MESH_CACHE:
        d = mesh_dir()
        for ext in (".off", ".ply"):
            p = d / (name + ext)
            if p.exists():
                _MESH_CACHE[name] = read_mesh(p)
                break
        else:
            raise KeyError(f"no mesh named {name!r} in {d}")
    return _MESH_CACHE[name]
