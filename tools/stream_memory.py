"""Peak memory and time of `nhnet-cli estimate` in memory against `--stream` on the same clouds,
and how far the streamed normals are from the in-memory ones (issue 10: a cloud larger than RAM
completes). Prints one markdown table.

    /usr/bin/python3 tools/stream_memory.py --method mfps --threads 2 CLOUD.xyz [CLOUD.xyz ...]

Peak RSS is the child's own (os.wait4); bytes per point = peak RSS / points. Both runs use the
same --tile-points (default 1000000), so the in-memory column is the in-memory tiling (the whole
cloud and its result held, one tile's working set on top) and the streamed one holds a tile only.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run(cmd):
    t0 = time.monotonic()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    _, status, ru = os.wait4(p.pid, 0)
    out, err = p.stdout.read().decode(), p.stderr.read().decode()
    p.stdout.close()
    p.stderr.close()
    rc = os.waitstatus_to_exitcode(status)
    if rc != 0:
        sys.exit(f"{' '.join(cmd)} exited {rc}:\n{err}")
    return time.monotonic() - t0, ru.ru_maxrss * 1024, out, err


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("clouds", nargs="+", help="XYZ text clouds")
    ap.add_argument("--cli", default="build/cli/nhnet-cli")
    ap.add_argument("--method", default="mfps")
    ap.add_argument("--threads", default="2")
    ap.add_argument("--tile-points", default="1000000")
    ap.add_argument("--temp-dir", default="", help="where outputs and tiles go (default: a new /tmp folder)")
    a = ap.parse_args()
    work = Path(a.temp_dir or tempfile.mkdtemp(prefix="nhnet-stream-memory-"))
    print("| cloud | points | in memory: s | peak B/point | --stream: s | peak B/point | tiles | "
          "mean diff deg |")
    print("|---|---|---|---|---|---|---|---|")
    for cloud in a.clouds:
        name = Path(cloud).stem
        common = ["--method", a.method, "--threads", a.threads, "--tile-points", a.tile_points,
                  "--orient", "none", "--quiet", "--json", "--overwrite"]
        mem_out, str_out = work / f"{name}.mem.xyzn", work / f"{name}.str.xyzn"
        tm, rm, js_m, _ = run([a.cli, "estimate", cloud, str(mem_out)] + common)
        ts, rs, js_s, _ = run([a.cli, "estimate", cloud, str(str_out), "--stream",
                               "--temp-dir", str(work)] + common)
        jm, jst = json.loads(js_m), json.loads(js_s)
        n = jm["points"]
        _, _, ev, _ = run([a.cli, "eval", str(str_out), str(mem_out), "--json"])
        diff = json.loads(ev)["mean_deg"]
        print(f"| {name} | {n} | {tm:.1f} | {rm / n:.0f} | {ts:.1f} | {rs / n:.0f} | "
              f"{jst['tiles']} | {diff:.4f} |", flush=True)
        mem_out.unlink()
        str_out.unlink()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
