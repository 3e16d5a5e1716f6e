"""tools/fit_confidence.py (issue 57) on small real clouds: `data` stores the core's features and
the errors, `fit` writes weights the C++ compiles from (every array the right length), `report`
and `check` give AUROCs in [0, 1] with the shipped weights. About 20 s on 2 cores."""
import re
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tools"))
import fit_confidence as fc  # noqa: E402

SAMPLE = REPO / "data" / "sample" / "fandisk_noise0.6.gt.xyzn"


def fake_split(root):
    """A datagen-shaped tree: two training clouds and two test clouds cut from the sample."""
    xyzn = np.loadtxt(SAMPLE)
    (root / "train").mkdir(parents=True)
    (root / "benchmark" / "PCPNetNoise").mkdir(parents=True)
    for i, lvl in enumerate(("0.3", "1.2")):
        np.savetxt(root / "train" / f"part_noise{lvl}.gt.xyzn", xyzn[i * 3000:(i + 1) * 3000])
        np.savetxt(root / "benchmark" / "PCPNetNoise" / f"fan_noise{'0.6' if i else '0'}.gt.xyzn",
                   xyzn[10000 + i * 3000:10000 + (i + 1) * 3000])


def test_data_fit_report_check(tmp_path, capsys):
    fake_split(tmp_path / "data")
    feat = tmp_path / "feat"
    for split in ("train", "test"):
        assert fc.main(["data", "--split", split, "--data", str(tmp_path / "data"), "--out",
                        str(feat), "--methods", "pca,mfps,nhnet", "--threads", "2"]) == 0
    z = np.load(feat / "train" / "part_noise0.3.mfps.npz")
    assert z["feats"].shape == (3000, fc.FEATURES) and z["err"].shape == (3000,)
    inc = tmp_path / "w.inc"
    assert fc.main(["fit", str(feat), "--write", str(inc), "--epochs", "3"]) == 0
    text = inc.read_text()
    for name in fc.WEIGHT_NAMES.values():
        block = text.split(f"constexpr ConfidenceWeights {name}{{", 1)[1].split("};", 1)[0]
        numbers = re.findall(r"-?\d+\.?\d*(?:e[-+]?\d+)?", block)
        # mean, scale (INPUTS each), w1 (HIDDEN x INPUTS), b1, w2 (HIDDEN each), b2
        assert len(numbers) == 2 * fc.INPUTS + fc.HIDDEN * fc.INPUTS + 2 * fc.HIDDEN + 1, name
    capsys.readouterr()
    assert fc.main(["report", str(feat), "--methods", "mfps"]) == 0
    out = capsys.readouterr().out
    assert "| mfps | 0.6 | 1 |" in out and "Reliability, mfps" in out
    assert fc.main(["check", "--method", "pca", str(SAMPLE)]) == 0
    row = capsys.readouterr().out.strip().splitlines()[-1].split("|")
    auc = float(row[5])
    assert 0.5 < auc <= 1  # the shipped weights rank the sample's errors better than chance
