"""Input and output of nhnet.distributed, chunk by chunk (every function runs on a worker).

A *source* describes where the points are without holding them: one large file cut into chunks
(binary PLY / PCD by row ranges, XYZ / ASCII PLY / ASCII PCD text by byte ranges, aligned to
lines), or a folder of tile files (one chunk per file, read whole by the core's reader). The
client parses headers only. Outputs: binary PLY / PCD written in place at each chunk's offsets
into one preallocated file, text written as one part per chunk and joined, or one file per tile
through the core's writer; always to a temporary name first.
"""

import glob
import os

import numpy as np

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
    "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
_PCD_TYPES = {("F", 4): "f4", ("F", 8): "f8", ("I", 1): "i1", ("I", 2): "i2", ("I", 4): "i4",
              ("I", 8): "i8", ("U", 1): "u1", ("U", 2): "u2", ("U", 4): "u4", ("U", 8): "u8"}
CHUNK_BYTES = 32 << 20  # default bytes of input per chunk (one scan / bin / write task each)
TEXT_EXTS = (".xyz", ".xyzn", ".txt", ".pts", ".asc")


class SourceError(ValueError):
    """A bad input, with the file's name in the message."""


def _ply_header(path, head):
    end = head.find(b"end_header")
    if end < 0:
        raise SourceError(f"{path}: PLY header without end_header")
    nl = head.index(b"\n", end)
    lines = head[:end].decode("ascii", "replace").splitlines()
    fmt, count, props, elem = None, 0, [], None
    for line in lines:
        w = line.split()
        if not w:
            continue
        if w[0] == "format":
            fmt = w[1]
        elif w[0] == "element":
            if elem == "vertex" and w[1] != "vertex":
                elem = "done"
            elif elem is None:
                if w[1] != "vertex":
                    raise SourceError(f"{path}: the first PLY element must be vertex")
                elem, count = "vertex", int(w[2])
        elif w[0] == "property" and elem == "vertex":
            if w[1] == "list":
                raise SourceError(f"{path}: list properties in vertices are not supported")
            if w[1] not in _PLY_TYPES:
                raise SourceError(f"{path}: unknown PLY type {w[1]}")
            props.append((w[2], _PLY_TYPES[w[1]]))
    names = [p[0] for p in props]
    if not all(c in names for c in "xyz"):
        raise SourceError(f"{path}: no x y z vertex properties")
    src = {"path": path, "count": count, "data": nl + 1, "names": names}
    if fmt == "ascii":
        src.update(kind="text", columns=[names.index(c) for c in "xyz"])
    elif fmt in ("binary_little_endian", "binary_big_endian"):
        e = "<" if fmt == "binary_little_endian" else ">"
        src.update(kind="binary", dtype=[(n, e + t) for n, t in props])
    else:
        raise SourceError(f"{path}: unknown PLY format {fmt}")
    return src


def _pcd_header(path, head):
    fields, sizes, types, counts, points, pos = [], [], [], None, None, 0
    for raw in head.split(b"\n"):
        pos += len(raw) + 1
        w = raw.decode("ascii", "replace").split()
        if not w or w[0].startswith("#"):
            continue
        key = w[0].upper()
        if key == "FIELDS":
            fields = w[1:]
        elif key == "SIZE":
            sizes = [int(x) for x in w[1:]]
        elif key == "TYPE":
            types = w[1:]
        elif key == "COUNT":
            counts = [int(x) for x in w[1:]]
        elif key == "POINTS":
            points = int(w[1])
        elif key == "DATA":
            data = w[1].lower()
            break
    else:
        raise SourceError(f"{path}: PCD header without DATA")
    if not all(c in fields for c in "xyz"):
        raise SourceError(f"{path}: no x y z fields")
    counts = counts or [1] * len(fields)
    src = {"path": path, "count": points, "data": pos, "names": fields}
    if data == "ascii":
        cols, at = [], 0
        for f, c in zip(fields, counts):
            if f in "xyz" and len(f) == 1:
                cols.append((f, at))
            at += c
        src.update(kind="text", columns=[dict(cols)[c] for c in "xyz"])
    elif data == "binary":
        dtype = []
        for i, (f, s, t, c) in enumerate(zip(fields, sizes, types, counts)):
            if (t, s) not in _PCD_TYPES:
                raise SourceError(f"{path}: unknown PCD type {t}{s}")
            name = f if f not in (d[0] for d in dtype) and f != "_" else f"_pad{i}"
            dtype.append((name, "<" + _PCD_TYPES[(t, s)], (c,)) if c > 1 else
                         (name, "<" + _PCD_TYPES[(t, s)]))
        src.update(kind="binary", dtype=dtype)
    else:
        raise SourceError(f"{path}: PCD DATA {data} is not supported by nhnet.distributed "
                          "(binary or ascii; convert with nhnet-cli)")
    return src


def describe_file(path, chunk_bytes=CHUNK_BYTES):
    """The source of one file, from its header only (the client's only read of the input), cut
    into chunks of about `chunk_bytes`."""
    try:
        with open(path, "rb") as f:
            head = f.read(1 << 16)
    except OSError as e:
        raise SourceError(f"{path}: cannot read: {e.strerror}") from None
    size = os.path.getsize(path)
    if head.startswith(b"ply"):
        src = _ply_header(path, head)
    elif head.lstrip().upper().startswith((b"# .PCD", b"VERSION", b"FIELDS")):
        src = _pcd_header(path, head)
    else:
        src = {"path": path, "kind": "text", "data": 0, "count": None, "columns": [0, 1, 2]}
    src["size"] = size
    if src["kind"] == "binary":
        item = np.dtype(src["dtype"]).itemsize
        if src["data"] + src["count"] * item > size:
            raise SourceError(f"{path}: {src['count']} points declared, the file holds "
                              f"{max(0, size - src['data']) // item}")
        rows = max(1, chunk_bytes // item)
        src["chunks"] = [(a, min(a + rows, src["count"]))
                         for a in range(0, src["count"], rows)] or [(0, 0)]
    else:
        step = max(1, chunk_bytes)
        src["chunks"] = [(a, min(a + step, size))
                         for a in range(src["data"], size, step)] or [(size, size)]
    return src


def describe_folder(pattern):
    """The tiles of a folder (every file in it) or a glob: one chunk each."""
    if os.path.isdir(pattern):
        files = sorted(os.path.join(pattern, n) for n in os.listdir(pattern)
                       if os.path.isfile(os.path.join(pattern, n)) and not n.startswith("."))
        root = pattern
    else:
        files = sorted(glob.glob(pattern))
        root = os.path.commonpath(files) if len(files) > 1 else os.path.dirname(pattern)
    if not files:
        raise SourceError(f"{pattern}: no input files")
    return {"kind": "folder", "root": root, "files": files}


def chunks(source):
    """Chunk descriptions (dicts, shippable) of a source."""
    if source["kind"] == "folder":
        return [{"kind": "file", "path": p} for p in source["files"]]
    base = {k: source[k] for k in ("path", "kind", "data") if k in source}
    for k in ("dtype", "columns"):
        if k in source:
            base[k] = source[k]
    return [dict(base, begin=a, end=b) for a, b in source["chunks"]]


def _text_rows(chunk, columns):
    """x y z of the data lines that start in the chunk's byte range (a line belongs to the chunk
    its first byte is in)."""
    path, begin, end = chunk["path"], chunk["begin"], chunk["end"]
    with open(path, "rb") as f:
        if begin > chunk["data"]:
            f.seek(begin - 1)
            skipped = f.readline()  # the line under way at begin - 1 belongs to the chunk before
            begin = begin - 1 + len(skipped)
        else:
            f.seek(begin)
        text = f.read(max(0, end - begin))
        if end > begin and not text.endswith(b"\n"):
            text += f.readline()
    if not text.strip():
        return np.empty((0, 3))
    text = text.replace(b",", b" ").replace(b"\r", b"")
    try:
        vals = np.loadtxt(text.decode("ascii", "replace").splitlines(), comments=("#", "//"),
                          usecols=columns, ndmin=2, dtype=np.float64)
    except ValueError as e:
        raise SourceError(f"{path}: bytes {begin}-{end}: {e}") from None
    return vals.reshape(-1, 3)


def read_chunk(chunk):
    """The chunk's points (n, 3) float64, in input order; non-finite rows kept."""
    if chunk["kind"] == "file":
        import nhnet  # noqa: PLC0415  (the worker's copy of the bindings)
        try:
            return np.asarray(nhnet.read(chunk["path"]).points, dtype=np.float64)
        except Exception as e:  # noqa: BLE001  (any reader error names the file)
            raise SourceError(f"{chunk['path']}: {e}") from None
    if chunk["kind"] == "binary":
        dtype = np.dtype(chunk["dtype"])
        rec = np.fromfile(chunk["path"], dtype=dtype, count=chunk["end"] - chunk["begin"],
                          offset=chunk["data"] + chunk["begin"] * dtype.itemsize)
        return np.stack([rec[c].astype(np.float64) for c in "xyz"], axis=1)
    return _text_rows(chunk, chunk["columns"])


def coordinate_type(source):
    """'f4' when the input's coordinates are float, else 'f8'."""
    if source.get("kind") == "binary":
        t = dict((d[0], d[1]) for d in source["dtype"])["x"]
        return "f4" if t.endswith("f4") else "f8"
    return "f8"


def output_kind(path):
    ext = os.path.splitext(path)[1].lower()
    if ext == ".ply":
        return "ply"
    if ext == ".pcd":
        return "pcd"
    if ext in TEXT_EXTS:
        return "text"
    raise SourceError(f"{path}: output must be .ply, .pcd or {', '.join(TEXT_EXTS)}")


def output_header(kind, count, ctype):
    """Header of a binary output file: x y z (ctype) then float normals."""
    if kind == "ply":
        t = "float" if ctype == "f4" else "double"
        return ("ply\nformat binary_little_endian 1.0\ncomment written by nhnet.distributed\n"
                f"element vertex {count}\nproperty {t} x\nproperty {t} y\nproperty {t} z\n"
                "property float nx\nproperty float ny\nproperty float nz\nend_header\n").encode()
    s = 4 if ctype == "f4" else 8
    return ("# .PCD v0.7 - written by nhnet.distributed\nVERSION 0.7\n"
            "FIELDS x y z normal_x normal_y normal_z\n"
            f"SIZE {s} {s} {s} 4 4 4\nTYPE F F F F F F\nCOUNT 1 1 1 1 1 1\n"
            f"WIDTH {count}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {count}\n"
            "DATA binary\n").encode()


def output_dtype(ctype):
    return np.dtype([("x", "<" + ctype), ("y", "<" + ctype), ("z", "<" + ctype),
                     ("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")])


def write_rows(path, offset, points, normals, ctype):
    """Writes rows into the preallocated binary output at byte `offset` (idempotent)."""
    rec = np.empty(len(points), dtype=output_dtype(ctype))
    for i, c in enumerate("xyz"):
        rec[c] = points[:, i]
        rec["n" + c] = normals[:, i]
    with open(path, "r+b") as f:
        f.seek(offset)
        f.write(rec.tobytes())
        f.flush()
        os.fsync(f.fileno())


def write_text_part(path, points, normals):
    """One chunk's lines x y z nx ny nz, to a temporary name then renamed (idempotent)."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as f:
        if len(points):
            np.savetxt(f, np.hstack([points, normals]),
                       fmt=["%.17g"] * 3 + ["%.9g"] * 3)
    os.replace(tmp, path)
