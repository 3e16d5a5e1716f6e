"""Wall seconds per stage of one estimate (and orientation), from the core's progress callback
(issue 23).

    PYTHONPATH=build/python /usr/bin/python3 tools/stage_timing.py CLOUD.xyz \
        [--method mfps] [--orient mst|none] [--threads 2]
    /usr/bin/python3 tools/stage_timing.py CLOUD.xyz --cli build/cli/nhnet-cli \
        [--method nhnet] [--orient none] [--threads 2] [-- --stream --tile-points 1000000]

Reads the cloud with nhnet.read(), runs nhnet.estimate() with a progress callback and charges
the time between two callbacks to the stage the first one named ("neighbours", "mfps planes",
"orient: mst", ...). Prints the total and each stage's seconds, in order of first appearance.
With --cli, times one whole `nhnet-cli estimate CLOUD OUT` process instead (what the Python API
does not run: `--stream`, given after `--`), from its progress bar: the bar is drawn on a
terminal only, so its stderr is a pseudo-terminal here; `start` is the time before the first
bar, each stage's seconds are summed over the tiles.
"""

from __future__ import annotations

import argparse
import os
import pty
import re
import subprocess
import sys
import tempfile
import time


def charge(seconds: dict[str, float], last: dict, stage: str | None) -> None:
    """The time since the last change to the last stage; `stage` is current from now."""
    now = time.perf_counter()
    if last["stage"] is not None:
        seconds[last["stage"]] = seconds.get(last["stage"], 0.0) + now - last["t"]
    last["t"], last["stage"] = now, stage


def api_stages(args) -> dict[str, float]:
    import nhnet
    points = nhnet.read(args.cloud).points  # not timed: the estimate's stages only
    seconds: dict[str, float] = {}
    last = {"t": time.perf_counter(), "stage": None}

    def progress(_fraction: float, stage: str) -> bool:
        charge(seconds, last, stage)
        return True

    nhnet.estimate(points, method=args.method, threads=args.threads,
                   orient=None if args.orient == "none" else args.orient, progress=progress)
    charge(seconds, last, None)
    return seconds


def cli_stages(args, extra: list[str]) -> dict[str, float]:
    """Stage seconds of one nhnet-cli process, split at each change of the name before its bar
    ("neighbours [#####.....]  40 %  3.1 s")."""
    seconds: dict[str, float] = {}
    last = {"t": time.perf_counter(), "stage": "start"}
    master, slave = pty.openpty()
    with tempfile.TemporaryDirectory(prefix="nhnet-stages-") as tmp:
        cmd = [args.cli, "estimate", args.cloud, os.path.join(tmp, "out.xyzn"), "--method",
               args.method, "--orient", args.orient, "--threads", str(args.threads),
               "--overwrite", *extra]
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=slave)
        os.close(slave)
        rest = b""
        while True:
            try:
                chunk = os.read(master, 65536)
            except OSError:  # EIO: the child closed the terminal
                break
            if not chunk:
                break
            *lines, rest = re.split(rb"[\r\n]", rest + chunk)
            for line in lines:
                text = line.decode(errors="replace").replace("\x1b[K", "")
                name = text.split("[")[0].strip() if "[" in text else None
                if name and name != last["stage"]:
                    charge(seconds, last, name)
        os.close(master)
        if proc.wait() != 0:
            sys.exit(f"failed ({proc.returncode}): {' '.join(cmd)}")
    charge(seconds, last, None)
    return seconds


def main() -> None:
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[: argv.index("--")] if "--" in argv else argv
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cloud")
    ap.add_argument("--method", default="mfps")
    ap.add_argument("--orient", default="none", choices=["mst", "none"])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--cli", help="time this nhnet-cli's whole estimate process instead")
    args = ap.parse_args(argv)
    seconds = cli_stages(args, extra) if args.cli else api_stages(args)
    print(f"total {sum(seconds.values()):.2f} s")
    for stage, s in seconds.items():
        print(f"{stage:<24} {s:6.2f}")


if __name__ == "__main__":
    main()
