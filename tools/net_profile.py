"""Where the NH-Net network's CPU time goes, layer by layer (issue 23).

    /usr/bin/python3 tools/net_profile.py [--model models/nhnet.pt] [--batch 4096]
        [--threads 2] [--reps 3] [--precision float32|bfloat16]

Loads the model as the core does (model_torch.cpp: frozen, then optimize_for_inference), runs
`reps` timed batches of random descriptors after two warm-up batches, and prints the points per
second, the BLAS library's speed on one matrix product (Debian's torch takes whichever
libblas.so.3 the system provides: the reference BLAS is ~18x slower than BLIS), and oneDNN's
own time per primitive (ONEDNN_VERBOSE, milliseconds summed over the timed
batches; the run re-executes itself with the variable set, as oneDNN reads it once at start).
"""

from __future__ import annotations

import argparse
import collections
import os
import subprocess
import sys
import time


def child(args) -> None:
    import torch

    torch.set_num_threads(args.threads)
    import json

    dtype = torch.bfloat16 if args.precision == "bfloat16" else torch.float32
    # As model_torch.cpp's to_low_precision: the weights cast before freezing, only the layers the
    # metadata names when it names some (the descriptors then stay float32), else all of them
    # and the descriptors fed in that type.
    files = {"nhnet.json": ""}
    loaded = torch.jit.load(args.model, _extra_files=files).eval()
    parts = json.loads(files["nhnet.json"] or "{}").get("bfloat16_modules", [])
    if dtype != torch.float32 and parts:
        for name in parts:
            getattr(loaded, name).to(dtype)
    else:
        loaded = loaded.to(dtype)
    m = torch.jit.optimize_for_inference(torch.jit.freeze(loaded))
    x = torch.randn(args.batch, 468)
    x[:, 27:] *= 0.3
    x = x.to(torch.float32 if parts else dtype)
    with torch.inference_mode():
        for _ in range(2):
            m(x)
        print("TIMED", flush=True)
        t = time.perf_counter()
        for _ in range(args.reps):
            m(x)
        wall = time.perf_counter() - t
    print(f"POINTS_PER_S {args.batch * args.reps / wall:.0f}", flush=True)
    a, b = torch.randn(4096, 441), torch.randn(441, 288)  # a matrix product of the MLP's size
    a @ b
    t = time.perf_counter()
    for _ in range(10):
        a @ b
    print(f"BLAS_GFLOPS {2 * 4096 * 441 * 288 * 10 / (time.perf_counter() - t) / 1e9:.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--model", default="models/nhnet.pt")
    ap.add_argument("--batch", type=int, default=4096)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--precision", choices=["float32", "bfloat16"], default="float32",
                    help="the network's arithmetic, as nhnet-cli --precision")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args)
        return
    env = dict(os.environ, ONEDNN_VERBOSE="1", DNNL_VERBOSE="1")
    out = subprocess.run([sys.executable, __file__, "--child", "--model", args.model, "--batch",
                          str(args.batch), "--threads", str(args.threads), "--reps",
                          str(args.reps), "--precision", args.precision], env=env,
                         capture_output=True, text=True, check=True)
    timed, pps, gflops = False, "?", "?"
    ms: dict[tuple[str, str, str], float] = collections.OrderedDict()
    for line in out.stdout.splitlines():
        if line == "TIMED":
            timed = True
        elif line.startswith("POINTS_PER_S"):
            pps = line.split()[1]
        elif line.startswith("BLAS_GFLOPS"):
            gflops = line.split()[1]
            timed = False  # the BLAS probe is no part of the model's primitives
        elif timed and line.startswith(("onednn_verbose,exec", "dnnl_verbose,exec")):
            f = line.split(",")
            key = (f[3], f[4], f[-2])
            ms[key] = ms.get(key, 0.0) + float(f[-1])
    total = sum(ms.values()) or 1.0
    print(f"{pps} points/s ({args.threads} threads, batch {args.batch}, {args.reps} batches, "
          f"{args.precision})")
    print(f"matrix products through BLAS (libblas.so.3): {gflops} GFLOP/s (4096x441 by 441x288)")
    print(f"oneDNN primitives: {total:.0f} ms in all\n")
    print("| primitive | implementation | shape | ms | share |")
    print("|---|---|---|---|---|")
    for (prim, impl, shape), v in ms.items():
        print(f"| {prim} | {impl} | {shape} | {v:.0f} | {100 * v / total:.0f} % |")


if __name__ == "__main__":
    main()
