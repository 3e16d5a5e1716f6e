"""The core's rooms depend on each other one way only (issue 26; docs/design/architecture.md):
io -> neighbors -> geometry -> learned -> orient -> pipeline, with denoise and eval beside orient
and util/ plus the base headers (types, errors, progress, version) below all. A file may include
its own room and the rooms before it, never one after it or a sibling. This test reads every
#include "..." of core/src and core/include/nhnet and fails on an arrow that points back.
"""

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
RANK = {"base": 0, "util": 0, "io": 1, "neighbors": 2, "geometry": 3, "learned": 4,
        "orient": 5, "denoise": 5, "eval": 5, "pipeline": 6}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def room_of_file(path):
    """Room of a file under core/src/<room>/ or core/include/nhnet/<room>/."""
    rel = path.relative_to(REPO / "core")
    parts = rel.parts
    if parts[0] == "src":
        return parts[1] if len(parts) > 2 else "base"
    return parts[2] if len(parts) > 3 else "base"


def room_of_include(name):
    """Room of an include as written: "nhnet/<room>/x.hpp", "nhnet/x.hpp" or "<room>/x.hpp"."""
    parts = name.split("/")
    if parts[0] == "nhnet":
        return parts[1] if len(parts) > 2 else "base"
    return parts[0] if len(parts) > 1 else None


# The umbrella header for users includes every room on purpose; nothing in the core includes it.
UMBRELLA = REPO / "core" / "include" / "nhnet" / "nhnet.hpp"


def core_files():
    for sub in ("src", "include/nhnet"):
        for p in sorted((REPO / "core" / sub).rglob("*")):
            if p.suffix in (".cpp", ".hpp", ".in") and p != UMBRELLA:
                yield p


def test_nothing_in_the_core_includes_the_umbrella():
    users = [str(path.relative_to(REPO)) for path in core_files()
             if "nhnet/nhnet.hpp" in INCLUDE.findall(path.read_text())]
    assert not users, f"core files including nhnet/nhnet.hpp: {users}"


def arrows():
    for path in core_files():
        src = room_of_file(path)
        for name in INCLUDE.findall(path.read_text()):
            dst = room_of_include(name)
            if dst is not None:
                yield path.relative_to(REPO), src, name, dst


def test_every_room_is_known():
    rooms = {src for _, src, _, _ in arrows()} | {dst for _, _, _, dst in arrows()}
    assert rooms <= set(RANK), f"rooms without a place in the flow: {sorted(rooms - set(RANK))}"


def test_arrows_point_one_way():
    # Siblings of one rank may not include each other, except the foundation (base and util).
    back = [f"{path}: {src} includes {name} ({dst})" for path, src, name, dst in arrows()
            if src != dst and (RANK[dst] > RANK[src] or (RANK[dst] == RANK[src] and RANK[src] > 0))]
    assert not back, "includes against the flow:\n" + "\n".join(back)
