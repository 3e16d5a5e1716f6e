#!/usr/bin/env python3
"""Accuracy of one method of one benchmark run against one of another, cloud by cloud (issue 23).

    /usr/bin/python3 tools/compare_records.py A/records.jsonl METHOD_A B/records.jsonl METHOD_B

Reads two `bench/nhnet_bench.py` records files, keeps the records of the named methods without a
fixed K, pairs them by cloud and prints a markdown table per category and overall: the mean over
the clouds of RMS, mean error and PGP10 for A and for B, and the largest change of a cloud's RMS.
Only clouds present in both count (their number is printed). E.g. the network in bfloat16
against the committed v7 run: `tools/compare_records.py docs/benchmark/nhnet-v7/records.jsonl
nhnet docs/benchmark/precision/records.jsonl nhnet-bf16`.
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict


def load(path: str, method: str) -> dict[tuple[str, str], dict]:
    out = {}
    with open(path) as f:
        for line in f:
            r = json.loads(line)
            if r.get("method") == method and not r.get("k"):
                out[(r["category"], r["cloud"])] = r
    return out


def row(name: str, keys: list, a: dict, b: dict, largest: bool = True) -> str:
    mean = lambda d, f: sum(d[k][f] for k in keys) / len(keys)  # noqa: E731
    cells = [f"{mean(a, 'rms_deg'):.3f}", f"{mean(b, 'rms_deg'):.3f}",
             f"{mean(a, 'mean_deg'):.3f}", f"{mean(b, 'mean_deg'):.3f}",
             f"{100 * mean(a, 'pgp10'):.2f}", f"{100 * mean(b, 'pgp10'):.2f}"]
    worst = max(abs(a[k]["rms_deg"] - b[k]["rms_deg"]) for k in keys)
    return f"| {name} | {len(keys)} | " + " | ".join(cells) + (f" | {worst:.3f} |" if largest
                                                             else " | |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a")
    ap.add_argument("method_a")
    ap.add_argument("b")
    ap.add_argument("method_b")
    args = ap.parse_args(argv)
    a, b = load(args.a, args.method_a), load(args.b, args.method_b)
    keys = sorted(set(a) & set(b))
    if not keys:
        raise SystemExit(f"no cloud has both {args.method_a} in {args.a} and {args.method_b} in "
                         f"{args.b}")
    by_cat = defaultdict(list)
    for k in keys:
        by_cat[k[0]].append(k)
    A, B = args.method_a, args.method_b
    print(f"{len(keys)} clouds in both; A = {A} ({args.a}), B = {B} ({args.b})\n")
    print(f"| category | clouds | RMS A | RMS B | mean A | mean B | PGP10 % A | PGP10 % B | "
          f"largest change of a cloud's RMS |")
    print("|---|---|---|---|---|---|---|---|---|")
    for cat in sorted(by_cat):
        print(row(cat, by_cat[cat], a, b))
    print(row("all clouds", keys, a, b))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
