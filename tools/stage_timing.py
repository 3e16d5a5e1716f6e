"""Wall seconds per stage of one estimate (and orientation), from the core's progress callback
(issue 23).

    PYTHONPATH=build/python /usr/bin/python3 tools/stage_timing.py CLOUD.xyz \
        [--method mfps] [--orient mst|none] [--threads 2]

Reads the cloud with nhnet.read(), runs nhnet.estimate() with a progress callback and charges
the time between two callbacks to the stage the first one named ("neighbours", "mfps planes",
"orient: mst", ...). Prints the total and each stage's seconds, in order of first appearance.
"""

from __future__ import annotations

import argparse
import time

import nhnet


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cloud")
    ap.add_argument("--method", default="mfps")
    ap.add_argument("--orient", default="none", choices=["mst", "none"])
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    points = nhnet.read(args.cloud).points
    seconds: dict[str, float] = {}
    last = {"t": time.perf_counter(), "stage": None}

    def progress(_fraction: float, stage: str) -> bool:
        now = time.perf_counter()
        if last["stage"] is not None:
            seconds[last["stage"]] = seconds.get(last["stage"], 0.0) + now - last["t"]
        last["t"], last["stage"] = now, stage
        return True

    start = time.perf_counter()
    nhnet.estimate(points, method=args.method, threads=args.threads,
                   orient=None if args.orient == "none" else args.orient, progress=progress)
    progress(1.0, "")
    print(f"total {time.perf_counter() - start:.2f} s")
    for stage, s in seconds.items():
        print(f"{stage:<24} {s:6.2f}")


if __name__ == "__main__":
    main()
