"""bench/front.py's own arithmetic (its runs rebuild the core and take the whole test split, so
they are not a test): the references come out of a committed bench run as its table shows them,
sizes are checked before anything is built, and the table's bars are the measured ratios."""

import importlib.util
import json
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("front", REPO / "bench" / "front.py")
front = importlib.util.module_from_spec(spec)
spec.loader.exec_module(front)
V7 = REPO / "docs" / "benchmark" / "nhnet-v7"


def table_rms(category: str, label: str) -> float:
    """The RMS column of one row of the committed table.md."""
    text = (V7 / "table.md").read_text()
    section = text.split(f"## {category}\n")[1].split("\n## ")[0]
    (row,) = [r for r in section.splitlines() if r.startswith(f"| {label} |")]
    return float(row.split("|")[3])


def test_references_are_the_committed_tables():
    refs = front.references(V7 / "records.jsonl")
    for c in front.CATEGORIES:
        assert refs[c]["pca_auto"] == pytest.approx(table_rms(c, "nhnet pca (auto k)"), abs=0.006)
        best = table_rms(c, f"PCL NormalEstimationOMP (k={refs[c]['pcl_best_k']})")
        assert refs[c]["pcl_best"] == pytest.approx(best, abs=0.006)
    # RichFeature's best PCL neighbourhood is the smallest (the table: 13.51 at k=18)
    assert refs["RichFeature"]["pcl_best_k"] == 18


def test_sizes_are_checked_before_any_build(tmp_path):
    inc = tmp_path / "h4.inc"
    inc.write_text("// weights\n")
    model = REPO / "models" / "nhnet-v6.pt"
    sizes = front.parse_sizes(f"mfps,mix,h16,h4={inc},v6@{model},h4v6={inc}@{model}")
    assert sizes[:3] == [("mfps", "", ""), ("mix", "", ""), ("h16", "", "")]
    assert sizes[3] == ("h4", str(inc.resolve()), "")
    assert sizes[4] == ("v6", "", str(model.resolve()))
    assert sizes[5] == ("h4v6", str(inc.resolve()), str(model.resolve()))
    with pytest.raises(SystemExit, match="weights file not found"):
        front.parse_sizes(f"h4={tmp_path / 'missing.inc'}")
    with pytest.raises(SystemExit, match="model file not found"):
        front.parse_sizes(f"v6@{tmp_path / 'missing.pt'}")
    with pytest.raises(SystemExit, match="needs a weights file"):
        front.parse_sizes("h64")
    with pytest.raises(SystemExit, match="mfps runs no network"):
        front.parse_sizes(f"mfps@{model}")
    assert front.cli_args("mix") == ["--learned-fit", "off"]
    assert front.cli_args("v6", "m.pt") == ["--model", "m.pt"]
    assert front.bench_method("mix") == "nhnet-mix" and front.bench_method("h4") == "nhnet"


def test_report_states_the_bars_from_the_numbers():
    refs = {c: {"pca_auto": 10.0, "pcl_best": 12.5, "pcl_best_k": 50} for c in front.CATEGORIES}
    acc = {c: {"rms": 9.0, "mean": 5.0, "clouds": 3} for c in front.CATEGORIES}
    res = {"date": "d", "commit": "c", "command": "bench/front.py", "reference": "records.jsonl",
           "clouds": ["a.gt.xyzn"], "references": refs,
           "sizes": {"h16": {"accuracy": acc, "time": {"a.gt.xyzn": {"ratio": 6.5, "seconds": 58}}}}}
    md = front.report(res)
    assert "NH-Net model" not in md  # every size on the shipped model
    res["sizes"]["h16"]["model"] = "nhnet-v6.pt"
    assert "- NH-Net model: the shipped one, but h16 nhnet-v6.pt" in front.report(res)
    # 9 / 10 - 1 = -10 %, 9 / 12.5 - 1 = -28 %
    assert "| h16 | " + " | ".join(["-10.0 % / -28.0 %"] * 6) + " |" in md
    assert "| 9.00 / 5.00 | 6.50 (58 s) |" in md
    json.dumps(res)  # what results.json holds
