"""nhnet.distributed: the tiled estimator as a Dask job, on a laptop or a cluster.

    python3 -m nhnet.distributed estimate INPUT OUTPUT [--scheduler tcp://HOST:PORT]
        [--workers N] [--tile-points M] [--method pca|mfps|nhnet] [-k K] [--scales A,B,C]
        [--orient auto|keep|up|mst[:K]|viewpoint X Y Z|sensors|none] [--seed S] [--threads T]
        [--scratch DIR]

INPUT is one file (binary or ASCII PLY, binary or ASCII PCD, uncompressed LAS, XYZ text) or a
folder / glob of tile files (any format nhnet reads; their union is the cloud); OUTPUT is one
file (.ply, .pcd, .las for a LAS input, .xyz...) with the points in input order, or a folder of
tiles mirroring the input's. Defaults as nhnet-cli: the core's default_method(), --orient auto
decided once from the input's header by the core's rule (resolve_orient). The passes:
  1. scan: every chunk (byte or row range of the file, or one tile file) is read by a worker:
     count, box and a sample; the tile plan is placed on the sample (the core's plan_tiles);
  2. bin: every chunk's points into per-tile files in the scratch folder;
  3. the whole cloud's decisions, once: the noise probe tile by tile (rough then final, as the
     out-of-core run), noise level, spacing, sizes and halos, MFPS's candidate threshold;
  4. estimate: each tile plus its halo with those decisions (so a point's normal does not depend
     on the cut), oriented per point (viewpoint), up (per point, the near-vertical rest inside
     the tile and its halo) or by an MST per tile whose sign is reconciled
     with the neighbouring tiles over the halos, from a seed, then one outward vote;
  5. write: every chunk writes its own rows of the output.
The client holds only sizes, boxes and per-tile numbers; the points stay on the workers and the
scratch folder. Docs: docs/beyond-one-machine.md.
"""

import argparse
import heapq
import os
import shutil
import sys
import tempfile
import time

import numpy as np

import nhnet

from nhnet import distributed_io as dio
from nhnet import distributed_tasks as tasks

EXIT_BAD_INPUT = 2
EXIT_PARTIAL = 3
_SAMPLE = 200_000  # points of the plan's sample over the whole cloud


def _parse(argv):
    ap = argparse.ArgumentParser(prog="python3 -m nhnet.distributed",
                                 description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="command", required=True)
    e = sub.add_parser("estimate", help="estimate normals of a cloud on a Dask cluster")
    e.add_argument("input", help="a file (.ply .pcd .xyz ...) or a folder / glob of tiles")
    e.add_argument("output", help="a file (.ply .pcd .xyz ...) or, for a folder input, a folder")
    e.add_argument("--scheduler", help="address of a running scheduler (tcp://HOST:PORT); "
                   "default: a local cluster of --workers processes")
    e.add_argument("--workers", type=int, default=0,
                   help="local cluster: worker processes (default: the cores)")
    e.add_argument("--memory-limit", default="auto",
                   help="local cluster: memory per worker, e.g. 4GB, or 0 for none (default "
                   "auto: the machine's memory / --workers)")
    e.add_argument("--tile-points", type=int, default=1_000_000,
                   help="most points per tile (default 1000000)")
    e.add_argument("-m", "--method", choices=["pca", "mfps", "nhnet"],
                   help="default: the core's default_method(), as nhnet-cli (nhnet where the "
                   "model is installed and libtorch built in, else mfps)")
    e.add_argument("-k", "--k", type=int, default=0, help="PCA size (0 = from the noise level)")
    e.add_argument("--scales", help="MFPS patch sizes, e.g. 50,100,150 (default: from the noise)")
    e.add_argument("--seed", type=int, default=1, help="seed of MFPS's random planes (default 1)")
    e.add_argument("--model", help="NH-Net model file (--method nhnet)")
    e.add_argument("--device", default="auto", help="NH-Net device: auto, cpu, cuda")
    e.add_argument("--precision", choices=nhnet.PRECISIONS,
                   help="NH-Net arithmetic, as nhnet-cli --precision (default: the core's, "
                   f"{nhnet.PRECISIONS[0]})")
    e.add_argument("--cell-means", type=_cell_means, default="auto", metavar="auto|off|RATIO",
                   help="as nhnet-cli: dense clouds whose noise exceeds their spacing are "
                   "estimated on local means of their points (auto: the core's noise ratio), "
                   "from another noise ratio, or never (off)")
    conf = tasks._core()._default_confidence()
    e.add_argument("--confidence", action=argparse.BooleanOptionalAction, default=conf,
                   help="as nhnet-cli --confidence: also write each normal's confidence in "
                   "[0, 1] (PLY / PCD 'confidence', LAS extra bytes 'Confidence', text a 7th "
                   f"column, NaN where a point failed; default: the core's, {'on' if conf else 'off'})")
    e.add_argument("--orient", nargs="+", default=["auto"], metavar="MODE",
                   help="auto (default, as nhnet-cli: from the input's header), keep, up, "
                   "mst[:K], viewpoint X Y Z, sensors or none")
    e.add_argument("--threads", type=int, default=1, help="core threads per task (default 1)")
    e.add_argument("--halo", type=float, default=4.0,
                   help="tile halo in radii of the largest neighbourhood (default 4)")
    e.add_argument("--scratch", help="folder shared by every worker for the tile files "
                   "(default: next to the output)")
    e.add_argument("--chunk-bytes", type=int, default=dio.CHUNK_BYTES,
                   help="bytes of a single-file input per read / write task (default 32 MiB)")
    e.add_argument("--quiet", action="store_true", help="no progress bars")
    return ap.parse_args(argv)


def _cell_means(text):
    """--cell-means: the noise ratio from which (the core's parser: auto, off = 0, or a ratio)."""
    try:
        return tasks._core()._cell_means_ratio(text)
    except nhnet.InvalidOptions as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _orient(words):
    mode = words[0]
    if mode.startswith("mst"):
        k = int(mode.split(":")[1]) if ":" in mode else 18
        if k < 2 or len(words) > 1:
            raise dio.SourceError("--orient mst:K needs K >= 2")
        return {"mode": "mst", "k": k}
    if mode.startswith("viewpoint"):
        vals = (mode.split(":")[1].split(",") if ":" in mode else []) + words[1:]
        if len(vals) != 3:
            raise dio.SourceError("--orient viewpoint needs 3 coordinates X Y Z")
        return {"mode": "viewpoint", "viewpoint": [float(v) for v in vals]}
    if mode in ("none", "auto", "keep", "up", "sensors") and len(words) == 1:
        return {"mode": mode, "k": 18}
    raise dio.SourceError("--orient must be auto, keep, up, mst[:K], viewpoint X Y Z, sensors "
                          f"or none, got {' '.join(words)}")


def resolve_orient(orient, info, path):
    """The whole run's orientation from the input's header `info` (dio.header_cloud), by the
    core's rules (orient/auto.hpp resolve_orientation, same order and wording): input normals ->
    keep; a sensor -> viewpoint; an organized grid -> viewpoint at the origin; airborne -> up;
    else mst. Adds 'source', the one line the summary prints (nhnet-cli's orient_source)."""
    o = dict(orient, source="requested")
    if o["mode"] == "auto":
        if info["normals"]:
            o.update(mode="keep", source="input normals")
        elif info["sensor"]:
            p, name = info["sensor"]
            o.update(mode="viewpoint", viewpoint=list(p),
                     source=f"sensor from {name} at ({p[0]:g}, {p[1]:g}, {p[2]:g})")
        elif info["grid"]:
            w, h = info["grid"]
            o.update(mode="viewpoint", viewpoint=[0.0, 0.0, 0.0],
                     source=f"organized {w}x{h} grid: sensor at the origin")
        elif info["airborne"]:
            o.update(mode="up", source="airborne: up (+z)")
        else:
            o.update(mode="mst", source="no sensor in the file: MST")
    if o["mode"] == "keep" and not info["normals"]:
        raise dio.SourceError(f"{path}: --orient keep needs input normals (nx ny nz or "
                              "normal_x normal_y normal_z fields)")
    if o["mode"] == "sensors":
        raise dio.SourceError(f"{path}: --orient sensors needs a sensor per point (E57 scans), "
                              "which nhnet.distributed does not read; use nhnet-cli")
    return o


class Job:
    """One run: the client, the source, the scratch folder and the passes."""

    def __init__(self, args, client, log):
        self.a, self.client, self.log = args, client, log
        self.failed_inputs = []
        self.token = f"nhnet-{os.getpid()}-{time.time_ns()}"  # task names unique to this run
        method = args.method or tasks._core()._default_method()[0]
        self.options = {"method": method, "k": args.k, "seed": args.seed,
                        "scales": [int(s) for s in args.scales.split(",")] if args.scales else None,
                        "threads": args.threads, "halo": args.halo, "model": args.model,
                        "device": args.device, "precision": args.precision,
                        "cell_means": args.cell_means, "confidence": args.confidence}

    def _wait(self, futures, what, gather=True):
        """Waits for `futures` with a progress bar; their results when `gather` (small ones
        only: the client never holds points, probe rows or surface variations)."""
        from distributed import progress, wait  # noqa: PLC0415
        if not self.a.quiet and futures:
            self.log(f"{what}:")
            progress(futures)
            print(file=sys.stderr)
        if not gather:
            wait(futures)
            return futures
        return self.client.gather(futures)

    def run(self):
        a = self.a
        folder = os.path.isdir(a.input) or any(ch in a.input for ch in "*?[")
        self.source = dio.describe_folder(a.input) if folder else dio.describe_file(a.input, a.chunk_bytes)
        self.orient = None  # a folder's: from its files, after the scan
        if not folder:
            self._set_orient(resolve_orient(self.requested, dio.header_cloud(self.source),
                                            a.input))
        self.out_kind = "folder" if folder else dio.output_kind(a.output)
        parent = a.scratch or (os.path.dirname(os.path.abspath(a.output)) if not folder
                               else os.path.abspath(a.output))
        os.makedirs(parent, exist_ok=True)
        self.scratch = tempfile.mkdtemp(prefix=".nhnet-dask-", dir=parent)
        self.tmp = None
        try:
            return self._passes()
        finally:
            shutil.rmtree(self.scratch, ignore_errors=True)
            if self.tmp and os.path.exists(self.tmp):  # a failed run leaves no partial output
                os.remove(self.tmp)

    def _set_orient(self, orient):
        self.orient = orient
        self.log(f"method {self.options['method']}, orientation {orient['mode']} "
                 f"({orient['source']})")

    def _folder_orient(self, metas):
        """A folder's orientation: the rule of its first readable file, which every other file
        must give too (the same mode and sensor), else exit 2: one decision for the cloud."""
        facts = [(self.source["files"][i], m["facts"]) for i, m in enumerate(metas)
                 if not m["error"]]
        plans = []
        for path, f in facts:
            if f["several"] and self.requested["mode"] == "auto":
                raise dio.SourceError(f"{path}: points from several sensors (E57 scans): "
                                      "--orient sensors is not run by nhnet.distributed; give "
                                      "--orient mst or viewpoint X Y Z, or use nhnet-cli")
            plans.append((path, resolve_orient(self.requested, f, path)))
        first_path, first = plans[0]
        for path, o in plans[1:]:
            if (o["mode"], o.get("viewpoint")) != (first["mode"], first.get("viewpoint")):
                raise dio.SourceError(
                    f"{self.a.input}: the tile files ask for different orientations ("
                    f"{first_path}: {first['source']}; {path}: {o['source']}); give --orient")
        self._set_orient(first)

    def _scan(self):
        chunks = dio.chunks(self.source)
        per = max(1000, _SAMPLE // len(chunks))
        scans = [self.client.submit(tasks.scan_chunk, ch, per, self.a.seed + i, pure=False,
                                    key=f"{self.token}-scan-{i}") for i, ch in enumerate(chunks)]
        metas = self._wait([self.client.submit(lambda s: s[0], f, key=f"{self.token}-meta-{i}")
                            for i, f in enumerate(scans)], "reading")
        for ch, m in zip(chunks, metas):
            if m["error"]:
                if self.source["kind"] != "folder":
                    raise dio.SourceError(m["error"])
                self.failed_inputs.append(m["error"])
                self.log(f"error: {m['error']} (skipped; its output is not written)")
        ok = [i for i, m in enumerate(metas) if not m["error"]]
        finite = sum(metas[i]["finite"] for i in ok)
        if finite < 3:
            raise dio.SourceError(f"{self.a.input}: only {finite} finite points; at least 3 are "
                                  "needed")
        rows0 = np.concatenate([[0], np.cumsum([m["count"] if not m["error"] else 0
                                                for m in metas])]).astype(np.int64)
        layout = self.client.submit(tasks.plan, [scans[i] for i in ok], self.a.tile_points)
        return chunks, ok, rows0, layout, metas

    def _passes(self):
        c = self.client
        t0 = time.time()
        chunks, ok, rows0, layout, metas = self._scan()
        if self.orient is None:
            self._folder_orient(metas)
        lay = layout.result()
        self.log(f"{int(rows0[-1])} points ({lay['finite']} finite), {lay['tiles']} tiles, "
                 f"{len(ok)} chunks")
        binned = self._wait([c.submit(tasks.bin_chunk, chunks[i], i, int(rows0[i]), layout,
                                      self.scratch, key=f"{self.token}-bin-{i}") for i in ok], "binning")
        boxes, counts = {}, {}
        for b in binned:
            for t, (n, lo, hi) in b.items():
                counts[t] = counts.get(t, 0) + n
                olo, ohi = boxes.get(t, (lo, hi))
                boxes[t] = (np.minimum(olo, lo), np.maximum(ohi, hi))
        cells = (lay["plan"]["cell_lo"], lay["plan"]["cell_hi"])
        dec = self._decisions(boxes, counts, cells, lay["finite"])
        self.log(f"noise ratio {dec['noise_ratio']:.3g}, k {dec['k_smooth']}"
                 + (f", scales {dec['scales']}" if self.a.method != "pca" else "")
                 + (", through cell means" if dec["cell_means"] else "")
                 + (f", threshold {dec['variation_threshold']:.4g}"
                    if dec["variation_threshold"] >= 0 else ""))
        orient = dict(self.orient, centre=lay["frame"]["centre"], scale=lay["frame"]["scale"])
        results = self._wait([c.submit(tasks.estimate, t, boxes, dec, self.options, orient,
                                       rows0[:-1], self.scratch, key=f"{self.token}-estimate-{t}")
                              for t in sorted(boxes)], "estimating")
        if orient["mode"] == "mst":
            frame, path = self._sides(results, boxes, dec, orient)
            results = self._wait([c.submit(tasks.orient_tile, r["tile"], boxes, dec, self.options,
                                           orient, rows0[:-1], self.scratch, frame, path, r,
                                           key=f"{self.token}-orient-{r['tile']}")
                                  for r in results], "orienting")
        signs = self._signs(results, boxes) if orient["mode"] == "mst" else {}
        failed = self._write(chunks, ok, rows0, signs, metas)
        self.log(f"orientation: {orient['mode']} ({orient['source']})")
        self.log(f"{int(rows0[-1])} points, {failed} without a normal, "
                 f"{sum(r['candidates'] for r in results)} candidates, "
                 + (f"{sum(r['cell_means'] for r in results)} cell means, "
                    if dec["cell_means"] else "")
                 + f"{time.time() - t0:.1f} s")
        for w in sorted({w for r in results for w in r["warnings"]
                         if "degenerate" not in w and "duplicate" not in w}):
            self.log(f"warning: {w}")
        return EXIT_PARTIAL if self.failed_inputs else 0

    def _decisions(self, boxes, counts, cells, finite):
        """The noise probe (rough pass without halos, then the final one), sizes and halos, and
        MFPS's candidate threshold: computed on the workers, only the numbers come back."""
        c, a, tiles = self.client, self.a, [t for t in sorted(boxes) if counts[t] >= 3]
        nh = tasks._core()
        rough = [c.submit(tasks.probe, t, boxes, cells, 0.0, nh._probe_step(finite, True),
                          self.scratch, a.threads, key=f"{self.token}-probe-rough-{t}") for t in tiles]
        dec = c.submit(tasks.decide, rough, self.options, finite).result()
        fine = [c.submit(tasks.probe, t, boxes, cells, 2 * dec["far_radius"],
                         nh._probe_step(finite, False), self.scratch, a.threads,
                         key=f"{self.token}-probe-{t}") for t in tiles]
        self._wait(fine, "noise probe", gather=False)
        dec = c.submit(tasks.decide, fine, self.options, finite).result()
        if a.method != "pca" and not dec["cell_means"]:  # the means choose their own
            step = nh._variation_step(finite, 20_000_000)
            parts = [c.submit(tasks.variation, t, boxes, dec, step, self.scratch, a.threads,
                              key=f"{self.token}-variation-{t}") for t in sorted(boxes)]
            self._wait(parts, "surface variation", gather=False)
            dec["variation_threshold"] = c.submit(tasks.threshold, parts).result()
        return dec

    def _sides(self, results, boxes, dec, orient):
        """MST: the whole cloud's flood-fill grid, decided as one process decides it (the
        core's sides_grid_plan on the MST graph's spacing over every tile, then the first
        candidate whose leak summed over the tiles is below the limit), built on a worker from
        every tile's occupied voxels. Returns (frame, path of its cells), (None, None) when no
        grid is watertight: then no tile floods its own (an open tile always leaks)."""
        c, nh, tiles = self.client, tasks._core(), sorted(boxes)
        count = sum(r["near_count"] for r in results)
        boxed = [r for r in results if r["lo"] is not None]
        if count < 4 or not boxed:
            return None, None
        spacing = sum(r["near_sum"] for r in results) / count
        typical = c.submit(tasks.median_spacing, tiles, self.scratch,
                           key=f"{self.token}-median-spacing").result()
        lo = np.min([r["lo"] for r in boxed], axis=0)
        hi = np.max([r["hi"] for r in boxed], axis=0)
        hs, dilations, max_leak = nh._sides_grid_plan(lo, hi, spacing, typical)
        for i, (h, dil) in enumerate(zip(hs, dilations)):
            frame = nh._sides_grid_frame(lo, hi, h, dil)
            occ = [c.submit(tasks.occupy, t, frame, self.scratch,
                            key=f"{self.token}-occupy-{i}-{t}") for t in tiles]
            path = c.submit(tasks.fill_grid, frame, occ, self.scratch, f"g{i}",
                            key=f"{self.token}-grid-{i}")
            leaks = self._wait([c.submit(tasks.leak, t, self.a.threads, frame, path,
                                         self.scratch, max_leak,
                                         key=f"{self.token}-leak-{i}-{t}") for t in tiles],
                               f"flood-fill grid {i + 1}")
            leaked, points = sum(x[0] for x in leaks), sum(x[1] for x in leaks)
            capped = [t for t, x in zip(tiles, leaks) if x[2]]
            if points and leaked / points < max_leak and capped:
                # A lower bound under the limit: the capped tiles counted in full, as one
                # process counts (when every tile is capped the bound is above it: leaks).
                full = self._wait([c.submit(tasks.leak, t, self.a.threads, frame, path,
                                            self.scratch, key=f"{self.token}-leakall-{i}-{t}")
                                   for t in capped], f"flood-fill grid {i + 1}, full count")
                leaked = sum(x[0] for x in leaks if not x[2]) + sum(x[0] for x in full)
            if points and leaked / points < max_leak:
                self.log(f"orientation: one flood-fill grid for the whole cloud, voxel "
                         f"{h / orient['scale']:.4g}, leak {100 * leaked / points:.2f} %")
                return frame, path.result()
        return None, None

    def _signs(self, results, boxes):
        """MST: one sign per tile. Tiles agree with their neighbours over the halos (a maximum
        spanning tree over |agreement|, propagated from the tile of the highest point), then
        the whole cloud is turned outward by one vote, sum (p - centroid) . n, as the
        in-process MST's outward vote; a tie keeps the highest point's normal up (+z)."""
        c = self.client
        tiles = sorted(boxes)
        ov = self._wait([c.submit(tasks.overlap, t, self.scratch, key=f"{self.token}-overlap-{t}")
                         for t in tiles], "reconciling tile signs")
        w = {}
        for t, o in zip(tiles, ov):
            for u, (s, _) in o.items():
                key = (min(t, u), max(t, u))
                w[key] = w.get(key, 0.0) + s
        by = {r["tile"]: r for r in results}
        seed = max(tiles, key=lambda t: by[t]["top_z"])
        signs, heap = {seed: 1}, []

        def push(t):
            for (x, y), s in w.items():
                if t in (x, y):
                    u = y if x == t else x
                    if u not in signs:
                        heapq.heappush(heap, (-abs(s), t, u, s))

        push(seed)
        while heap:
            _, t, u, s = heapq.heappop(heap)
            if u in signs:
                continue
            signs[u] = signs[t] * (1 if s >= 0 else -1)
            push(u)
        for t in tiles:  # tiles that share no halo with the rest: their own MST's sign
            signs.setdefault(t, 1)
        count = sum(by[t]["valid"] for t in tiles)
        centre = sum(by[t]["p"] for t in tiles) / max(1, count)
        vote = sum(signs[t] * (by[t]["pn"] - float(centre @ by[t]["n"])) for t in tiles)
        scale = sum(abs(by[t]["pn"]) for t in tiles) + 1e-300
        flip = vote < 0 if abs(vote) > 1e-6 * scale else signs[seed] * by[seed]["top_nz"] < 0
        return {t: -s if flip else s for t, s in signs.items()}

    def _write(self, chunks, ok, rows0, signs, metas):
        c, a = self.client, self.a
        if self.out_kind == "folder":
            root = self.source["root"]
            paths = [os.path.join(a.output, os.path.relpath(ch["path"], root)) for ch in chunks]
            out = {"kind": "folder", "paths": paths}
        elif self.out_kind == "text":
            out = {"kind": "text"}
        else:
            ctype = dio.coordinate_type(self.source)
            if self.out_kind == "las":
                if self.source.get("kind") != "las":
                    raise dio.SourceError(f"{a.output}: LAS output needs a LAS input (its "
                                          "records are kept); write .ply or .pcd")
                lo = np.min([m["lo"] for m in metas if not m["error"]], axis=0)
                hi = np.max([m["hi"] for m in metas if not m["error"]], axis=0)
                header, itemsize = dio.las_output_header(self.source, lo, hi, a.confidence)
            else:
                header = dio.output_header(self.out_kind, int(rows0[-1]), ctype, a.confidence)
                itemsize = dio.output_dtype(ctype, a.confidence).itemsize
            self.tmp = f"{a.output}.tmp-dask{os.getpid()}"
            with open(self.tmp, "wb") as f:  # the client writes the header and sizes the file
                f.write(header)
                f.truncate(len(header) + int(rows0[-1]) * itemsize)
            out = {"kind": "las" if self.out_kind == "las" else "binary", "tmp": self.tmp,
                   "header": len(header), "ctype": ctype, "itemsize": itemsize}
        out["keep"] = self.orient["mode"] == "keep"
        out["confidence"] = a.confidence
        failed = sum(self._wait([c.submit(tasks.write_chunk, chunks[i], i, int(rows0[i]), signs,
                                          out, self.scratch, key=f"{self.token}-write-{i}") for i in ok],
                                "writing"))
        if self.out_kind == "text":
            self.tmp = f"{a.output}.tmp-dask{os.getpid()}"
            c.submit(tasks.join_parts, os.path.join(self.scratch, "parts"), len(ok), self.tmp,
                     key=f"{self.token}-join").result()
            os.replace(self.tmp, a.output)
        elif self.out_kind != "folder":
            os.replace(self.tmp, a.output)
        return failed


def _client(args, log):
    from distributed import Client, LocalCluster  # noqa: PLC0415
    if args.scheduler:
        client = Client(args.scheduler)
    else:
        n = args.workers or os.cpu_count() or 1
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                               memory_limit=0 if args.memory_limit == "0" else args.memory_limit)
        client = Client(cluster)
    try:
        import bokeh  # noqa: F401,PLC0415  (the dashboard's web pages need it)
        note = ""
    except ImportError:
        note = " (served only where the scheduler has bokeh, which Debian 12 does not package)"
    log(f"dashboard: {client.dashboard_link}{note}")
    return client


def main(argv=None):
    args = _parse(sys.argv[1:] if argv is None else argv)

    def log(msg):
        print(f"nhnet.distributed: {msg}", file=sys.stderr, flush=True)

    try:
        if args.tile_points < 1000:
            raise dio.SourceError("--tile-points must be at least 1000")
        orient = _orient(args.orient)
        if os.path.abspath(args.input) == os.path.abspath(args.output):
            raise dio.SourceError(f"{args.output}: the output would replace the input")
    except (dio.SourceError, ValueError) as e:
        log(f"error: {e}")
        return EXIT_BAD_INPUT
    client = _client(args, log)
    try:
        job = Job(args, client, log)
        job.requested = orient
        code = job.run()
    except dio.SourceError as e:
        log(f"error: {e}")
        return EXIT_BAD_INPUT
    finally:
        cluster = client.cluster if not args.scheduler else None
        client.close()
        if cluster is not None:
            cluster.close()
    if code == EXIT_PARTIAL:
        log(f"partial: {len(job.failed_inputs)} input(s) failed, the others were written")
    return code


if __name__ == "__main__":
    sys.exit(main())
