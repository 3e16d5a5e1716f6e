"""The tasks of nhnet.distributed: plain functions that Dask runs on the workers.

Every task is idempotent: it reads the input or the scratch folder, computes, and writes its
files under a temporary name renamed into place, so a task that a lost worker was running can
run again elsewhere and leave the same files. Tiles live in the scratch folder (shared by every
worker) as one .npy file per (tile, chunk): the chunk's points of that tile, their input rows and
frame coordinates. The algorithms are the core's (nhnet._nhnet's tile functions, tiles.hpp).
"""

import os

import numpy as np

from nhnet import distributed_io as dio

_BIN = np.dtype([("row", "<i8"), ("p", "<f8", (3,))])


def _save(path, **arrays):
    """np.savez to a temporary name, then renamed (idempotent, never half written)."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = f"{path}.tmp{os.getpid()}.npz"
    np.savez(tmp, **arrays)
    os.replace(tmp, path)


def _core():
    from nhnet import _nhnet  # noqa: PLC0415  (the worker's bindings)
    return _nhnet


def scan_chunk(chunk, sample_size, seed):
    """Pass 1: count, finite count, bounding box and a random sample of the chunk's points; an
    unreadable chunk (a corrupt tile file) gives {'error': message} instead of failing the job."""
    facts = None
    try:
        if chunk["kind"] == "file":
            cloud = dio.read_cloud(chunk["path"])
            pts, facts = np.asarray(cloud.points, dtype=np.float64), file_facts(cloud)
        else:
            pts = dio.read_chunk(chunk)
    except (dio.SourceError, OSError) as e:
        return {"error": str(e)}, None
    finite = np.isfinite(pts).all(axis=1)
    fp = pts[finite]
    meta = {"count": len(pts), "finite": int(finite.sum()), "error": None, "facts": facts,
            "lo": fp.min(axis=0) if len(fp) else None, "hi": fp.max(axis=0) if len(fp) else None}
    rng = np.random.default_rng(seed)
    take = min(len(fp), sample_size)
    sample = fp[rng.choice(len(fp), take, replace=False)] if take < len(fp) else fp
    return meta, sample


def file_facts(cloud):
    """dio.header_cloud's facts of a tile file read whole by the core's reader (folder inputs);
    'sensor' is None with 'several' set when its points come from more than one sensor."""
    used = set(np.unique(np.asarray(cloud.sensor_index)).tolist()) if len(cloud.sensor_index) else {0}
    sensor = None
    if len(cloud.sensors) and used == {0}:
        s = cloud.sensors[0]
        sensor = (np.asarray(s.position).reshape(3).tolist(), s.source)
    return {"normals": cloud.normals is not None, "sensor": sensor, "grid": cloud.grid,
            "airborne": bool(cloud.airborne), "several": len(used) > 1 and len(cloud.sensors) > 1}


def plan(scans, tile_points):
    """The frame and the tile plan from every chunk's box and sample (on a worker: the samples
    never reach the client)."""
    nh = _core()
    metas = [m for m, _ in scans if m["error"] is None and m["finite"]]
    lo = np.min([m["lo"] for m in metas], axis=0)
    hi = np.max([m["hi"] for m in metas], axis=0)
    centre, scale = nh._tile_frame(lo, hi)
    frame = {"centre": np.asarray(centre).reshape(3), "scale": float(scale)}
    sample = np.concatenate([s for m, s in scans if s is not None and len(s)])
    finite = sum(m["finite"] for m in metas)
    p = nh._plan_tiles((sample - frame["centre"]) * frame["scale"], finite, tile_points)
    return {"frame": frame, "plan": p, "tiles": len(p["cell_lo"]), "finite": finite}


def bin_chunk(chunk, c, row0, layout, scratch):
    """Pass 2: the chunk's finite points into one file per tile they fall in; returns each
    tile's count and box (frame units) from this chunk."""
    nh = _core()
    pts = dio.read_chunk(chunk)
    rows = np.arange(row0, row0 + len(pts), dtype=np.int64)
    finite = np.isfinite(pts).all(axis=1)
    frame = layout["frame"]
    p = (pts[finite] - frame["centre"]) * frame["scale"]
    rows = rows[finite]
    tile = nh._route_tiles(layout["plan"], p) if len(p) else np.empty(0, np.int32)
    out = {}
    for t in np.unique(tile):
        sel = tile == t
        rec = np.empty(int(sel.sum()), dtype=_BIN)
        rec["row"], rec["p"] = rows[sel], p[sel]
        path = os.path.join(scratch, "bins", f"t{t}", f"c{c}.npy")
        os.makedirs(os.path.dirname(path), exist_ok=True)
        tmp = f"{path}.tmp{os.getpid()}.npy"
        np.save(tmp, rec)
        os.replace(tmp, path)
        out[int(t)] = (len(rec), rec["p"].min(axis=0), rec["p"].max(axis=0))
    return out


def _bins(scratch, t):
    d = os.path.join(scratch, "bins", f"t{t}")
    names = sorted(n for n in os.listdir(d) if n.endswith(".npy") and ".tmp" not in n)
    return np.concatenate([np.load(os.path.join(d, n)) for n in names])


def load_tile(t, boxes, halo, scratch):
    """Tile t's own points (input order) then every point of the other tiles within `halo` of
    its box: (points, rows, owner tile of each row), as the out-of-core run's Tiles::load."""
    own = _bins(scratch, t)
    own = own[np.argsort(own["row"], kind="stable")]
    lo, hi = boxes[t][0] - halo, boxes[t][1] + halo
    parts, owners = [own], [np.full(len(own), t, np.int32)]
    for u, (ulo, uhi) in boxes.items():
        if u == t or (ulo > hi).any() or (uhi < lo).any():
            continue
        b = _bins(scratch, u)
        sel = ((b["p"] >= lo) & (b["p"] <= hi)).all(axis=1)
        if sel.any():
            parts.append(b[sel])
            owners.append(np.full(int(sel.sum()), u, np.int32))
    rec = np.concatenate(parts)
    return rec["p"], rec["row"], np.concatenate(owners), len(own)


def probe(t, boxes, cells, halo, step, scratch, threads):
    """Noise-probe rows of tile t (the core's probe_tile)."""
    pts, _, _, own = load_tile(t, boxes, halo, scratch)
    return _core()._probe_tile(pts, own, step, halo, cells[0][t], cells[1][t], threads)


def decide(rows, options, finite):
    """The whole cloud's decisions from every tile's probe rows (on a worker)."""
    return _core()._decide_tiles([r for r in rows if len(r[0])], options, finite)


def variation(t, boxes, decisions, step, scratch, threads):
    pts, _, _, own = load_tile(t, boxes, decisions["variation_halo"], scratch)
    return _core()._tile_variation(pts, own, decisions["k_smooth"], step, threads)


def threshold(parts):
    return float(_core()._variation_threshold(np.concatenate(parts)))


def estimate(t, boxes, decisions, options, orient, chunk_rows, scratch):
    """Tile t with its halo through the estimator with the whole cloud's decisions, oriented per
    point (viewpoint, up: per point where |n_z| >= up_min_z, the rest in the tile). MST: the
    normals of the tile and its halo are kept unoriented for orient_tile (after the whole
    cloud's flood-fill grid is decided), and the tile's terms of that decision come back: its
    own distinct valid points' nearest distances (saved) and their box."""
    nh = _core()
    pts, rows, owner, own = load_tile(t, boxes, decisions["halo"], scratch)
    normals, valid, cand, warnings, k_used, scales_used, means, conf = nh._estimate_tile(
        pts, options, decisions)
    base = {"tile": t, "own": own, "failed": int(own - valid[:own].sum()),
            "candidates": int(cand[:own].sum()) if len(cand) else 0, "warnings": warnings,
            "k_used": k_used, "scales_used": list(scales_used), "cell_means": means}
    if orient["mode"] == "mst":  # the MST's guides, fitted once for the leak counts and the MST
        gp, gg, near, row_guides = nh._mst_guides(pts, normals, own, orient["k"],
                                                  options["threads"])
        _save(os.path.join(scratch, "raw", f"t{t}.npz"), normals=normals, guides=row_guides,
              **({} if conf is None else {"confidence": conf[:own]}))
        _save(os.path.join(scratch, "guides", f"t{t}.npz"), p=gp, g=gg)
        _save(os.path.join(scratch, "near", f"t{t}.npz"), d=near)
        ok = np.isfinite(pts[:own]).all(axis=1) & np.isfinite(normals[:own]).all(axis=1) & \
            (np.abs(normals[:own]).sum(axis=1) > 0)
        p = pts[:own][ok]
        _save(os.path.join(scratch, "ownp", f"t{t}.npz"), p=p)  # for the grids' occupancy
        base.update(near_sum=float(near.sum()), near_count=len(near),
                    lo=p.min(axis=0) if len(p) else None, hi=p.max(axis=0) if len(p) else None)
        return base
    if orient["mode"] == "viewpoint":
        vp = (np.asarray(orient["viewpoint"]) - orient["centre"]) * orient["scale"]
        normals = nh.orient(pts, normals, "viewpoint", viewpoint=vp,
                            threads=options["threads"]).normals
    elif orient["mode"] == "up":
        normals = nh.orient(pts, normals, "up", threads=options["threads"]).normals
    return _finish(t, pts, rows, own, normals, chunk_rows, scratch, base, conf)


def median_spacing(tiles, scratch):
    """The median (nearest rank below, as the core's) of every tile's nearest distances."""
    d = np.concatenate([np.load(os.path.join(scratch, "near", f"t{t}.npz"))["d"]
                        for t in tiles] or [np.zeros(0)])
    if not len(d):
        return 0.0
    k = int(0.5 * (len(d) - 1))
    return float(np.partition(d, k)[k])


def occupy(t, frame, scratch):
    """The voxels of the grid `frame` that tile t's own points with a valid normal occupy."""
    p = np.load(os.path.join(scratch, "ownp", f"t{t}.npz"))["p"]
    return np.unique(_core()._sides_grid_voxels(frame, p))


def fill_grid(frame, occupied, scratch, name):
    """The whole cloud's grid: every tile's occupied voxels, dilated and flood-filled (the
    core's), saved as scratch/grid/<name>.npy; returns its path."""
    occ = np.unique(np.concatenate(occupied)) if occupied else np.zeros(0, np.int64)
    cell = _core()._fill_sides_grid(frame, occ)
    path = os.path.join(scratch, "grid", f"{name}.npy")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = f"{path}.tmp{os.getpid()}.npy"
    np.save(tmp, cell)
    os.replace(tmp, path)
    return path


def _grid(frame, path):
    return dict(frame, cell=np.load(path)) if path else None


def leak(t, threads, frame, path, scratch, max_leak=None):
    """(leaked, points, capped) of tile t's distinct valid own points on the grid at `path`,
    voting with the MST's guide normals (fitted once per tile by estimate). With `max_leak` the
    count stops once above that share of the tile's points (capped: then only a lower bound)."""
    g = np.load(os.path.join(scratch, "guides", f"t{t}.npz"))
    n = len(g["p"])
    limit = int(max_leak * n) + 1 if max_leak is not None else 0
    leaked = _core()._sides_leaked(g["p"], g["g"], _grid(frame, path), threads, limit)
    return leaked, n, limit > 0 and leaked >= limit


def orient_tile(t, boxes, decisions, options, orient, chunk_rows, scratch, frame, path, base):
    """MST: tile t and its halo oriented, voting on the whole cloud's grid at `path` (no flood
    fill when None: the single process found none watertight either); the halo's normals go to
    the tile's overlap file for the reconciliation between tiles."""
    pts, rows, owner, own = load_tile(t, boxes, decisions["halo"], scratch)
    raw = np.load(os.path.join(scratch, "raw", f"t{t}.npz"))
    normals = _core()._orient_mst_tile(pts, raw["normals"], orient["k"], options["threads"],
                                       _grid(frame, path), path is not None, raw["guides"])
    _save(os.path.join(scratch, "halo", f"t{t}.npz"), rows=rows[own:], owner=owner[own:],
          normals=normals[own:].astype(np.float32))
    _save(os.path.join(scratch, "own", f"t{t}.npz"), rows=rows[:own],
          normals=normals[:own].astype(np.float32))
    conf = raw["confidence"] if "confidence" in raw.files else None
    return _finish(t, pts, rows, own, normals, chunk_rows, scratch, base, conf)


def _finish(t, pts, rows, own, normals, chunk_rows, scratch, base, conf=None):
    """The own points' normals (and confidences, when estimated) to one file per input chunk;
    returns `base` with the tile's terms of the outward vote."""
    n, r = normals[:own].astype(np.float32), rows[:own]
    cf = None if conf is None else np.asarray(conf[:own], dtype=np.float32)
    chunk_of = np.searchsorted(chunk_rows, r, side="right") - 1
    for c in np.unique(chunk_of):
        sel = chunk_of == c
        _save(os.path.join(scratch, "res", f"c{c}", f"t{t}.npz"), rows=r[sel], normals=n[sel],
              **({} if cf is None else {"confidence": cf[sel]}))
    ok = np.isfinite(normals[:own]).all(axis=1)
    p, m = pts[:own][ok], normals[:own][ok]
    top = int(np.argmax(pts[:own, 2]))
    return dict(base, pn=float((p * m).sum()), n=m.sum(axis=0), p=p.sum(axis=0), valid=len(p),
                top_z=float(pts[top, 2]), top_nz=float(normals[top, 2]))


def overlap(t, scratch):
    """MST: for tile t's halo points, the agreement (sum of dot products) of t's normals with
    their owner tile's, per owner: {u: (sum, count)}."""
    h = np.load(os.path.join(scratch, "halo", f"t{t}.npz"))
    out = {}
    for u in np.unique(h["owner"]):
        sel = h["owner"] == u
        o = np.load(os.path.join(scratch, "own", f"t{u}.npz"))
        idx = np.searchsorted(o["rows"], h["rows"][sel])
        a, b = h["normals"][sel].astype(np.float64), o["normals"][idx].astype(np.float64)
        d = (a * b).sum(axis=1)
        d = d[np.isfinite(d)]
        out[int(u)] = (float(d.sum()), len(d))
    return out


def write_chunk(chunk, c, row0, signs, out, scratch):
    """Pass 4: the chunk's points with their normals (tile signs applied; NaN where none) and,
    when out["confidence"], their confidences (NaN where none) into the output: in place at the
    chunk's offset (binary), as a part file (text), or as the tile's own output file (folder
    input)."""
    pts = dio.read_chunk(chunk)
    normals = np.full((len(pts), 3), np.nan, np.float32)
    conf = np.full(len(pts), np.nan, np.float32) if out.get("confidence") else None
    d = os.path.join(scratch, "res", f"c{c}")
    if os.path.isdir(d):
        for name in os.listdir(d):
            if not name.endswith(".npz") or ".tmp" in name:
                continue
            t = int(name[1:-4])
            r = np.load(os.path.join(d, name))
            normals[r["rows"] - row0] = r["normals"] * np.float32(signs.get(t, 1))
            if conf is not None:
                conf[r["rows"] - row0] = r["confidence"]
    if out.get("keep"):  # the input normals' signs, per point (the core's orient_like)
        ref = dio.read_normals(chunk)
        flip = (normals.astype(np.float64) * ref).sum(axis=1) < 0
        normals[flip] = -normals[flip]
    if out["kind"] == "folder":
        import nhnet  # noqa: PLC0415
        os.makedirs(os.path.dirname(out["paths"][c]), exist_ok=True)
        nhnet.write(out["paths"][c], pts, normals.astype(np.float64),
                    confidence=None if conf is None else conf.astype(np.float64))
    elif out["kind"] == "las":
        dio.write_las_rows(chunk, out["tmp"], out["header"] + row0 * out["itemsize"], normals,
                           conf)
    elif out["kind"] == "text":
        dio.write_text_part(os.path.join(scratch, "parts", f"p{c:06d}.txt"), pts, normals, conf)
    else:
        dio.write_rows(out["tmp"], out["header"] + row0 * out["itemsize"], pts, normals,
                       out["ctype"], conf)
    return int(np.isnan(normals[:, 0]).sum())


def join_parts(parts_dir, count, target):
    """Text output: the chunks' parts joined in order into `target` (already a temporary name)."""
    with open(target, "wb") as f:
        for c in range(count):
            with open(os.path.join(parts_dir, f"p{c:06d}.txt"), "rb") as p:
                while True:
                    buf = p.read(1 << 24)
                    if not buf:
                        break
                    f.write(buf)
        f.flush()
        os.fsync(f.fileno())
    return target
