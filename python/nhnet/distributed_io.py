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
    if fmt in ("binary_little_endian", "binary_big_endian"):
        _ply_camera(path, lines, src, "<" if fmt == "binary_little_endian" else ">")
    if fmt == "ascii":
        src.update(kind="text", columns=[names.index(c) for c in "xyz"])
    elif fmt in ("binary_little_endian", "binary_big_endian"):
        e = "<" if fmt == "binary_little_endian" else ">"
        src.update(kind="binary", dtype=[(n, e + t) for n, t in props])
    else:
        raise SourceError(f"{path}: unknown PLY format {fmt}")
    return src


def _ply_camera(path, lines, src, endian):
    """Binary PLY: the grid (camera viewport or obj_info num_cols / num_rows giving the vertex
    count) and PCL's camera element (its first row, read past the vertices) into src['grid'] /
    src['sensor'], as the core's PLY reader (io/ply.cpp set_sensor)."""
    elements, cols, rows = [], 0, 0
    for line in lines:
        w = line.split()
        if len(w) == 3 and w[0] == "obj_info" and w[2].isdigit():
            cols, rows = (int(w[2]), rows) if w[1] == "num_cols" else (
                (cols, int(w[2])) if w[1] == "num_rows" else (cols, rows))
        elif w and w[0] == "element":
            elements.append((w[1], int(w[2]), []))
        elif w and w[0] == "property" and elements:
            if w[1] == "list" or w[1] not in _PLY_TYPES:
                return  # a list element: its size is in the data, no camera read here
            elements[-1][2].append((w[2], endian + _PLY_TYPES[w[1]]))
    cam, at = None, src["data"]
    for name, count, props in elements:
        if name == "camera" and count > 0:
            cam = np.fromfile(path, dtype=props, count=1, offset=at)
            break
        at += count * np.dtype(props).itemsize
    grids = []
    if cam is not None and len(cam):
        grids.append(tuple(float(cam[0][v]) if v in cam.dtype.names else float("nan")
                           for v in ("viewportx", "viewporty")))
    grids.append((float(cols), float(rows)))
    for w, h in grids:
        if w >= 1 and h > 1 and w * h == src["count"]:
            src["grid"] = (int(w), int(h))
            break
    if cam is None or not len(cam):
        return
    val = {n: float(cam[0][n]) for n in cam.dtype.names}
    t = [val.get(f"view_p{c}", float("nan")) for c in "xyz"]
    if all(np.isnan(t)):
        return  # not PCL's camera
    if any(np.isnan(t)):
        raise SourceError(f"{path}: PLY camera: the sensor position is not finite")
    r = np.array([[val.get(f"{a}_axis{c}", 1.0 if a == b else 0.0) for c in "xyz"]
                  for b, a in enumerate("xyz")])
    default = all(v == 0 for v in t) and np.abs(r - np.eye(3)).max() <= 1e-6
    src["viewpoint"] = None if default else t + [1, 0, 0, 0]
    src["sensor_name"] = "PLY camera"
    if default and "grid" in src:
        src["viewpoint"] = t + [1, 0, 0, 0]


def _pcd_header(path, head):
    fields, sizes, types, counts, points, pos = [], [], [], None, None, 0
    grid, viewpoint = {}, None
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
        elif key in ("WIDTH", "HEIGHT"):
            grid[key] = int(w[1])
        elif key == "VIEWPOINT" and len(w) == 8:
            viewpoint = [float(x) for x in w[1:]]
        elif key == "DATA":
            data = w[1].lower()
            break
    else:
        raise SourceError(f"{path}: PCD header without DATA")
    if not all(c in fields for c in "xyz"):
        raise SourceError(f"{path}: no x y z fields")
    counts = counts or [1] * len(fields)
    src = {"path": path, "count": points, "data": pos, "names": fields,
           "grid": (grid.get("WIDTH", 0), grid.get("HEIGHT", 1)), "viewpoint": viewpoint}
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


def _las_header(path, head):
    """LAS: the point records' place, size, count, scale and offset (public header block)."""
    if len(head) < 227:
        raise SourceError(f"{path}: LAS header shorter than 227 bytes")
    minor, hsize = head[25], int.from_bytes(head[94:96], "little")
    fmt = head[104]
    if fmt & 0xC0:
        raise SourceError(f"{path}: compressed (LAZ) input cannot be read in chunks by "
                          "nhnet.distributed: decompress it to LAS first (laszip -i IN.laz -o "
                          "OUT.las, or pdal translate), or give a folder of LAZ tiles (each "
                          "tile read whole)")
    count = int.from_bytes(head[107:111], "little")
    if minor >= 4 and hsize >= 375 and len(head) >= 255:
        count = int.from_bytes(head[247:255], "little") or count
    record = int.from_bytes(head[105:107], "little")
    if record < 12:
        raise SourceError(f"{path}: LAS point records of {record} bytes (at least 12)")
    return {"path": path, "kind": "las", "count": count, "format": fmt, "record": record,
            "data": int.from_bytes(head[96:100], "little"),
            "scale": np.frombuffer(head[131:155], "<f8").tolist(),
            "offset": np.frombuffer(head[155:179], "<f8").tolist(),
            "dtype": [("X", "<i4"), ("Y", "<i4"), ("Z", "<i4"), ("rest", f"V{record - 12}")]}


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
    elif head.startswith(b"LASF"):
        src = _las_header(path, head)
    elif head.startswith(b"ASTM-E57"):
        raise SourceError(f"{path}: a single E57 file is not cut into chunks by "
                          "nhnet.distributed (its scans are compressed binary sections); give a "
                          "folder of E57 / LAS / PLY tiles (each read whole), or use nhnet-cli")
    elif head.lstrip().upper().startswith((b"# .PCD", b"VERSION", b"FIELDS")):
        src = _pcd_header(path, head)
    else:
        src = {"path": path, "kind": "text", "data": 0, "count": None, "columns": [0, 1, 2]}
    src["size"] = size
    if src["kind"] in ("binary", "las"):
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
    for k in ("dtype", "columns", "scale", "offset", "normals"):
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


def read_cloud(path):
    """A tile file read whole by the core's reader (the worker's copy of the bindings)."""
    import nhnet  # noqa: PLC0415
    try:
        return nhnet.read(path)
    except Exception as e:  # noqa: BLE001  (any reader error names the file)
        raise SourceError(f"{path}: {e}") from None


def read_chunk(chunk):
    """The chunk's points (n, 3) float64, in input order; non-finite rows kept."""
    if chunk["kind"] == "file":
        return np.asarray(read_cloud(chunk["path"]).points, dtype=np.float64)
    if chunk["kind"] in ("binary", "las"):
        rec = _records(chunk)
        if chunk["kind"] == "las":  # X * scale + offset, as the core's LAS reader
            return np.stack([rec[c] * s + o for c, s, o in
                             zip("XYZ", chunk["scale"], chunk["offset"])], axis=1)
        return np.stack([rec[c].astype(np.float64) for c in "xyz"], axis=1)
    return _text_rows(chunk, chunk["columns"])


def _records(chunk):
    dtype = np.dtype(chunk["dtype"])
    return np.fromfile(chunk["path"], dtype=dtype, count=chunk["end"] - chunk["begin"],
                       offset=chunk["data"] + chunk["begin"] * dtype.itemsize)


def read_normals(chunk):
    """The chunk's input normals (n, 3) float64 (orient keep), from the fields `describe_file`
    found (source['normals']) or the core's reader (a tile file)."""
    if chunk["kind"] == "file":
        import nhnet  # noqa: PLC0415
        n = nhnet.read(chunk["path"]).normals
        if n is None:
            raise SourceError(f"{chunk['path']}: no normals to keep")
        return np.asarray(n, dtype=np.float64)
    if chunk["kind"] != "binary" or not chunk.get("normals"):
        raise SourceError(f"{chunk['path']}: orient keep reads normals from binary PLY / PCD "
                          "only in nhnet.distributed")
    rec = _records(chunk)
    return np.stack([rec[c].astype(np.float64) for c in chunk["normals"]], axis=1)


_NORMAL_NAMES = (("nx", "ny", "nz"), ("normal_x", "normal_y", "normal_z"))


def header_cloud(source):
    """What the input's header says about its sensor, as the core's readers set it (cloud.hpp):
    {'normals': bool, 'sensor': (position, source) or None, 'grid': (w, h) or None,
    'airborne': bool}. PCD: VIEWPOINT (kept when not the default pose or the cloud is
    organized) and WIDTH x HEIGHT; LAS: airborne; PLY and text name no sensor here."""
    info = {"normals": False, "sensor": None, "grid": None, "airborne": False}
    if source.get("kind") == "las":
        info["airborne"] = True
        return info
    names = source.get("names") or []
    for trio in _NORMAL_NAMES:
        if all(n in names for n in trio):
            info["normals"] = True
            source["normals"] = list(trio)
    w, h = source.get("grid") or (0, 1)  # PCD: WIDTH x HEIGHT; PLY: _ply_camera
    if h > 1 and w > 0:
        info["grid"] = (w, h)
    vp = source.get("viewpoint")
    if vp is not None:
        default = ("sensor_name" not in source and all(v == 0 for v in vp[:3])
                   and all(abs(q) < 1e-6 for q in vp[4:]))
        if info["grid"] or not default:
            info["sensor"] = (vp[:3], source.get("sensor_name", "PCD VIEWPOINT"))
    return info


def coordinate_type(source):
    """'f4' when the input's coordinates are float, else 'f8'."""
    if source.get("kind") == "binary" and source.get("dtype"):
        t = dict((d[0], d[1]) for d in source["dtype"])["x"]
        return "f4" if t.endswith("f4") else "f8"
    return "f8"


def output_kind(path):
    ext = os.path.splitext(path)[1].lower()
    if ext == ".ply":
        return "ply"
    if ext == ".las":
        return "las"
    if ext == ".pcd":
        return "pcd"
    if ext in TEXT_EXTS:
        return "text"
    raise SourceError(f"{path}: output must be .ply, .pcd, .las (LAS input) or "
                      f"{', '.join(TEXT_EXTS)}")


def output_header(kind, count, ctype, confidence=False):
    """Header of a binary output file: x y z (ctype), float normals, then a float confidence
    when asked (the core's writers' name for it: PLY / PCD `confidence`)."""
    if kind == "ply":
        t = "float" if ctype == "f4" else "double"
        return ("ply\nformat binary_little_endian 1.0\ncomment written by nhnet.distributed\n"
                f"element vertex {count}\nproperty {t} x\nproperty {t} y\nproperty {t} z\n"
                "property float nx\nproperty float ny\nproperty float nz\n"
                + ("property float confidence\n" if confidence else "")
                + "end_header\n").encode()
    s = 4 if ctype == "f4" else 8
    c = (" confidence", " 4", " F", " 1") if confidence else ("",) * 4
    return ("# .PCD v0.7 - written by nhnet.distributed\nVERSION 0.7\n"
            f"FIELDS x y z normal_x normal_y normal_z{c[0]}\n"
            f"SIZE {s} {s} {s} 4 4 4{c[1]}\nTYPE F F F F F F{c[2]}\nCOUNT 1 1 1 1 1 1{c[3]}\n"
            f"WIDTH {count}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {count}\n"
            "DATA binary\n").encode()


def output_dtype(ctype, confidence=False):
    return np.dtype([("x", "<" + ctype), ("y", "<" + ctype), ("z", "<" + ctype),
                     ("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
                    + ([("confidence", "<f4")] if confidence else []))


def write_rows(path, offset, points, normals, ctype, confidence=None):
    """Writes rows into the preallocated binary output at byte `offset` (idempotent)."""
    rec = np.empty(len(points), dtype=output_dtype(ctype, confidence is not None))
    for i, c in enumerate("xyz"):
        rec[c] = points[:, i]
        rec["n" + c] = normals[:, i]
    if confidence is not None:
        rec["confidence"] = confidence
    with open(path, "r+b") as f:
        f.seek(offset)
        f.write(rec.tobytes())
        f.flush()
        os.fsync(f.fileno())


def write_text_part(path, points, normals, confidence=None):
    """One chunk's lines x y z nx ny nz (and the confidence, a 7th column, when given), to a
    temporary name then renamed (idempotent)."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = f"{path}.tmp{os.getpid()}"
    cols = [points, normals] + ([] if confidence is None else [confidence.reshape(-1, 1)])
    with open(tmp, "w") as f:
        if len(points):
            np.savetxt(f, np.hstack(cols), fmt=["%.17g"] * 3 + ["%.9g"] * (len(cols) + 1))
    os.replace(tmp, path)


_LAS_STANDARD = (20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67)  # record bytes per point format
_LAS_EXTRA_SIZE = (0, 1, 1, 2, 2, 4, 4, 8, 8, 4, 8)          # extra-bytes data types 0..10


def _descriptor(name, data_type, options=0):
    d = bytearray(192)
    d[2], d[3] = data_type, options
    d[4:4 + len(name)] = name.encode()[:32]
    return bytes(d)


def _vlr(user, rid, payload, description):
    h = bytearray(54)
    h[2:2 + len(user)] = user.encode()
    h[18:20] = rid.to_bytes(2, "little")
    h[20:22] = len(payload).to_bytes(2, "little")
    h[22:22 + len(description)] = description.encode()
    return bytes(h) + payload


def las_output_header(source, lo, hi, confidence=False):
    """Header and VLRs of the LAS output of a LAS input, as the core's LAS writer makes them
    (io/las_write.cpp, a cloud read from LAS written back): the input's header and VLRs, each
    record kept and widened by NormalX/Y/Z (and, when asked, Confidence) float32 extra-bytes
    fields described in a rebuilt extra-bytes VLR after the others; counts, offsets and the
    bounds [lo, hi] patched. Returns (bytes, new record length)."""
    path = source["path"]
    with open(path, "rb") as f:
        head = f.read(source["data"])
    hsize, nvlr, minor = (int.from_bytes(head[94:96], "little"),
                          int.from_bytes(head[100:104], "little"), head[25])
    evlrs = (int.from_bytes(head[227:235], "little") != 0 if minor == 3 else
             minor >= 4 and int.from_bytes(head[243:247], "little") > 0)
    if evlrs:
        raise SourceError(f"{path}: LAS output of a LAS with EVLRs (waveforms) is not written "
                          "by nhnet.distributed; write .ply / .pcd or use nhnet-cli")
    vlrs, extras, pos = [], [], hsize
    for _ in range(nvlr):
        if pos + 54 > len(head):
            raise SourceError(f"{path}: VLR at byte {pos} runs past the point data")
        user = head[pos + 2:pos + 18].split(b"\0")[0]
        rid = int.from_bytes(head[pos + 18:pos + 20], "little")
        n = int.from_bytes(head[pos + 20:pos + 22], "little")
        if user == b"LASF_Spec" and rid == 4:
            extras = [head[pos + 54 + i:pos + 54 + i + 192] for i in range(0, n - n % 192, 192)]
        elif not (user == b"laszip encoded" and rid == 22204):
            vlrs.append(head[pos:pos + 54 + n])
        pos += 54 + n
    fmt, record = source["format"] & 0x3F, source["record"]
    described = _LAS_STANDARD[fmt] if fmt <= 10 else 0
    for d in extras:
        if d[2] == 0:
            described += d[3]
        elif 1 <= d[2] <= 30:
            described += _LAS_EXTRA_SIZE[(d[2] - 1) % 10 + 1] * ((d[2] - 1) // 10 + 1)
        name = d[4:36].split(b"\0")[0].decode("ascii", "replace").lower()
        if "normal" in name or (confidence and name == "confidence"):
            raise SourceError(f"{path}: the input already has {name} fields; nhnet.distributed "
                              "writes LAS only from inputs without them (use nhnet-cli)")
    gap = record - described
    while gap > 0:
        extras.append(_descriptor("", 0, min(gap, 255)))
        gap -= min(gap, 255)
    added = ("NormalX", "NormalY", "NormalZ") + (("Confidence",) if confidence else ())
    extras += [_descriptor(n, 9) for n in added]
    vlrs.append(_vlr("LASF_Spec", 4, b"".join(extras), "extra bytes"))
    h = bytearray(head[:hsize])
    offset = hsize + sum(len(v) for v in vlrs)
    n = source["count"]
    h[104] = fmt
    h[105:107] = (record + 4 * len(added)).to_bytes(2, "little")
    h[96:100] = offset.to_bytes(4, "little")
    h[100:104] = len(vlrs).to_bytes(4, "little")
    h[107:111] = (n if fmt < 6 and n <= 0xFFFFFFFF else 0).to_bytes(4, "little")
    for k in range(3):
        h[179 + 16 * k:187 + 16 * k] = np.float64(hi[k]).tobytes()
        h[187 + 16 * k:195 + 16 * k] = np.float64(lo[k]).tobytes()
    if minor >= 4:
        h[243:247] = (0).to_bytes(4, "little")
        h[247:255] = n.to_bytes(8, "little")
        h[235:243] = (0).to_bytes(8, "little")
    return bytes(h) + b"".join(vlrs), record + 4 * len(added)


def write_las_rows(chunk, path, offset, normals, confidence=None):
    """The chunk's input records, unchanged, each followed by its normal (float32 NormalX/Y/Z)
    and, when given, its confidence (float32 Confidence), written in place at byte `offset` of
    the preallocated LAS output (idempotent)."""
    raw = np.fromfile(chunk["path"], dtype=f"V{np.dtype(chunk['dtype']).itemsize}",
                      count=chunk["end"] - chunk["begin"],
                      offset=chunk["data"] + chunk["begin"] * np.dtype(chunk["dtype"]).itemsize)
    rec = np.empty(len(raw), dtype=[("r", raw.dtype), ("n", "<f4", (3,))]
                   + ([("c", "<f4")] if confidence is not None else []))
    rec["r"], rec["n"] = raw, normals
    if confidence is not None:
        rec["c"] = confidence
    with open(path, "r+b") as f:
        f.seek(offset)
        f.write(rec.tobytes())
        f.flush()
        os.fsync(f.fileno())
