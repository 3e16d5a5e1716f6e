#!/usr/bin/env python3
"""Fits the per-point confidence (core/src/learned/confidence.cpp, confidence_weights.inc) and
reports how well it ranks the errors (issue 57).

Three steps; `data` is resumable (a cloud's file is written once, atomically):

    # per point: the core's confidence features (nhnet.confidence_features) and the angle error
    # of each method's normals, on generated clouds (nhnet-datagen, 20 000 points)
    PYTHONPATH=training /usr/bin/python3 -m nhnet_training.datagen --out runs/conf/data \\
        --set train --points 20000
    PYTHONPATH=training /usr/bin/python3 -m nhnet_training.datagen --out runs/conf/data \\
        --set benchmark --categories PCPNetNoise --points 20000
    PYTHONPATH=build/python /usr/bin/python3 tools/fit_confidence.py data --split train \\
        --data runs/conf/data --out runs/conf/feat
    PYTHONPATH=build/python /usr/bin/python3 tools/fit_confidence.py data --split test \\
        --data runs/conf/data --out runs/conf/feat
    # fit each method on the training split only, write the C++ weights
    /usr/bin/python3 tools/fit_confidence.py fit runs/conf/feat \\
        --write core/src/learned/confidence_weights.inc
    # on the held-out PCPNetNoise clouds, with the weights the core runs: AUROC per noise level,
    # beside the surface variation's, and the reliability table
    PYTHONPATH=build/python /usr/bin/python3 tools/fit_confidence.py report runs/conf/feat
    # any clouds with ground truth (e.g. 1M points, through cell means), the whole pipeline
    PYTHONPATH=build/python /usr/bin/python3 tools/fit_confidence.py check --method mfps X.gt.xyzn

The training split is the datagen `train` set at noise 0, 0.3, 0.6 and 1.2 % (uniform sampling);
the test split is the benchmark's PCPNetNoise category (35 held-out models at 0, 0.125, 0.6 and
1.2 %). A point counts as wrong when its unoriented error exceeds 30 degrees; the network scores
that chance (binary cross-entropy, every cloud weighing the same), the confidence is one minus it.
AUROC: of (1 - confidence) for "error > 30 deg", per cloud by ranks, averaged over the clouds of a
level that have both kinds of points.
"""
from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

import numpy as np

FEATURES, HIDDEN = 8, 16
INPUTS = 2 * FEATURES - 1
METHODS = ("pca", "mfps", "nhnet")
WEIGHT_NAMES = {"pca": "kPcaWeights", "mfps": "kMfpsWeights", "nhnet": "kNhNetWeights"}
TRAIN_LEVELS = ("0", "0.3", "0.6", "1.2")
WRONG_DEG = 30.0


def split_files(data: Path, split: str) -> list[Path]:
    if split == "train":
        return sorted(f for lvl in TRAIN_LEVELS
                      for f in (data / "train").glob(f"*_noise{lvl}.gt.xyzn")
                      if "_gradient" not in f.name and "_stripes" not in f.name)
    return sorted((data / "benchmark" / "PCPNetNoise").glob("*.gt.xyzn"))


def cmd_data(a) -> int:
    import nhnet
    out = Path(a.out) / a.split
    out.mkdir(parents=True, exist_ok=True)
    files = split_files(Path(a.data), a.split)
    if not files:
        print(f"fit_confidence: no clouds for split {a.split} under {a.data}", file=sys.stderr)
        return 2
    for f in files:
        name = f.name[: -len(".gt.xyzn")]
        for method in a.methods.split(","):
            dst = out / f"{name}.{method}.npz"
            if dst.exists():
                continue
            xyzn = np.loadtxt(f)
            pts, gt = xyzn[:, :3], xyzn[:, 3:]
            r = nhnet.estimate(pts, method=method, orient=None, threads=a.threads)
            feats = nhnet.confidence_features(pts, r.normals, r.curvature, r.noise_ratio)
            err = nhnet.angle_errors(r.normals, gt)
            tmp = dst.with_suffix(".tmp.npz")
            np.savez(tmp, feats=feats, err=err)
            tmp.replace(dst)
            print(f"{name} {method}: RMS {np.sqrt(np.nanmean(err ** 2)):.2f}", flush=True)
    return 0


def load(feat: Path, split: str, method: str):
    """[(cloud name, noise level, features, errors)] of the rows with a normal."""
    out = []
    for f in sorted((feat / split).glob(f"*.{method}.npz")):
        z = np.load(f)
        F, e = z["feats"], z["err"]
        ok = np.isfinite(e) & np.isfinite(F).all(1)
        name = f.name[: -len(f".{method}.npz")]
        out.append((name, name.rsplit("_noise", 1)[1], F[ok], e[ok]))
    return out


def inputs(F: np.ndarray) -> np.ndarray:
    """The network's inputs, as the C++ makes them: the features, then the square roots of all
    but the last (the log noise ratio)."""
    return np.concatenate([F, np.sqrt(np.clip(F[:, :-1], 0, None))], 1)


def make_net(torch, mean, scale):
    class Net(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.register_buffer("mean", torch.as_tensor(mean, dtype=torch.float64))
            self.register_buffer("scale", torch.as_tensor(scale, dtype=torch.float64))
            self.l1 = torch.nn.Linear(INPUTS, HIDDEN).double()
            self.l2 = torch.nn.Linear(HIDDEN, 1).double()

        def forward(self, x):  # logit of P(error > 30 deg)
            return self.l2(torch.tanh(self.l1((x - self.mean) / self.scale)))[:, 0]
    return Net()


def fit_method(torch, clouds, epochs: int, seed: int):
    X = [inputs(F) for _, _, F, _ in clouds]
    allx = np.concatenate(X)
    torch.manual_seed(seed)
    net = make_net(torch, allx.mean(0), allx.std(0) + 1e-9)
    xs = [torch.as_tensor(x) for x in X]
    ys = [torch.as_tensor((e > WRONG_DEG).astype(np.float64)) for _, _, _, e in clouds]
    opt = torch.optim.Adam(net.parameters(), lr=1e-2)
    bce = torch.nn.functional.binary_cross_entropy_with_logits
    for ep in range(epochs):
        opt.zero_grad()
        loss = sum(bce(net(x), y) for x, y in zip(xs, ys)) / len(xs)  # every cloud the same
        loss.backward()
        opt.step()
        if ep % 50 == 0 or ep == epochs - 1:
            print(f"  epoch {ep}: loss {loss.item():.4f}", flush=True)
    return net


def fmt(v) -> str:
    return "{" + ", ".join(f"{float(t):.9g}" for t in np.ravel(v)) + "}"


def cmd_fit(a) -> int:
    import torch
    torch.set_num_threads(a.threads)
    feat = Path(a.feat)
    blocks = []
    for method in METHODS:
        clouds = load(feat, "train", method)
        if not clouds:
            print(f"fit_confidence: no training data for {method} under {feat}", file=sys.stderr)
            return 2
        print(f"{method}: {len(clouds)} clouds", flush=True)
        net = fit_method(torch, clouds, a.epochs, a.seed)
        p = {k: v.detach().numpy() for k, v in net.state_dict().items()}
        w1 = ",\n     ".join(fmt(r) for r in p["l1.weight"])
        blocks.append(f"""constexpr ConfidenceWeights {WEIGHT_NAMES[method]}{{
    {fmt(p['mean'])},
    {fmt(p['scale'])},
    {{{{{w1}}}}},
    {fmt(p['l1.bias'])},
    {fmt(p['l2.weight'])},
    {float(p['l2.bias'][0]):.9g}}};""")
    text = (f"// Written by tools/fit_confidence.py (fit {a.feat} --epochs {a.epochs} --seed {a.seed});"
            "\n// do not edit. Weights of the per-point confidence (confidence.hpp), fitted on the"
            "\n// training split only.\n// clang-format off\n" + "\n".join(blocks) +
            "\n// clang-format on\n")
    path = Path(a.write)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(text)
    tmp.replace(path)
    print(f"wrote {path}")
    return 0


def auroc(score: np.ndarray, wrong: np.ndarray) -> float:
    """P(score of a wrong point > score of a right one), ties counted half; NaN without both."""
    from scipy.stats import rankdata
    npos = int(wrong.sum())
    nneg = len(wrong) - npos
    if npos == 0 or nneg == 0:
        return float("nan")
    r = rankdata(score)
    return float((r[wrong].sum() - npos * (npos + 1) / 2) / (npos * nneg))


def cmd_report(a) -> int:
    import nhnet
    feat = Path(a.feat)
    model = {"pca": nhnet.ConfidenceModel.pca, "mfps": nhnet.ConfidenceModel.mfps,
             "nhnet": nhnet.ConfidenceModel.nhnet}
    print("AUROC of (1 - confidence) for error > 30 deg, mean over the held-out clouds of a level "
          "(surface variation's beside it); the share of such points\n")
    print("| method | noise % | clouds | confidence | surface variation | over 30 deg |")
    print("|---|---|---|---|---|---|")
    for method in a.methods.split(","):
        clouds = load(feat, "test", method)
        per, rel = {}, []
        for name, lvl, F, e in clouds:
            c = nhnet.confidence_from_features(F, model[method])
            wrong = e > WRONG_DEG
            per.setdefault(lvl, []).append((auroc(-c, wrong), auroc(F[:, 0], wrong), wrong.mean()))
            if lvl != "0":
                rel.append((c, e))
        noisy = []
        for lvl in sorted(per, key=float):
            v = np.array(per[lvl])
            if lvl != "0":
                noisy.append(v)
            print(f"| {method} | {lvl} | {int(np.isfinite(v[:, 0]).sum())} | {np.nanmean(v[:, 0]):.3f} "
                  f"| {np.nanmean(v[:, 1]):.3f} | {100 * v[:, 2].mean():.1f} % |")
        v = np.concatenate(noisy)
        print(f"| {method} | **noisy (0.125-1.2)** | {int(np.isfinite(v[:, 0]).sum())} "
              f"| **{np.nanmean(v[:, 0]):.3f}** | {np.nanmean(v[:, 1]):.3f} | {100 * v[:, 2].mean():.1f} % |")
        rel_table(method, rel)
    return 0


def rel_table(method: str, rel) -> None:
    """Error (deg) median and 90th percentile per confidence decile, noisy clouds pooled."""
    c = np.concatenate([r[0] for r in rel])
    e = np.concatenate([r[1] for r in rel])
    edges = np.quantile(c, np.linspace(0, 1, 11))
    print(f"\nReliability, {method}, noisy held-out clouds pooled ({len(c)} points): "
          "error per confidence decile\n")
    print("| decile | confidence | median error deg | p90 error deg | over 30 deg |")
    print("|---|---|---|---|---|")
    for d in range(10):
        m = (c >= edges[d]) & ((c < edges[d + 1]) if d < 9 else (c <= edges[d + 1]))
        print(f"| {d + 1} | {edges[d]:.2f}-{edges[d + 1]:.2f} | {np.median(e[m]):.1f} "
              f"| {np.quantile(e[m], 0.9):.1f} | {100 * (e[m] > WRONG_DEG).mean():.1f} % |")
    print()


def cmd_check(a) -> int:
    """The pipeline's own confidence (nhnet.estimate(confidence=True)) on whole clouds."""
    import nhnet
    print("| cloud | method | points | cell means | AUROC confidence | AUROC surface variation "
          "| over 30 deg |")
    print("|---|---|---|---|---|---|---|")
    for f in a.clouds:
        xyzn = np.loadtxt(f)
        r = nhnet.estimate(xyzn[:, :3], method=a.method, orient=None, confidence=True,
                           threads=a.threads)
        e = nhnet.angle_errors(r.normals, xyzn[:, 3:])
        ok = np.isfinite(e)
        wrong = e[ok] > WRONG_DEG
        print(f"| {Path(f).name} | {a.method} | {len(xyzn)} | {r.cell_means} "
              f"| {auroc(-r.confidence[ok], wrong):.3f} | {auroc(r.curvature[ok], wrong):.3f} "
              f"| {100 * wrong.mean():.1f} % |", flush=True)
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    d = sub.add_parser("data", help="features and errors of generated clouds")
    d.add_argument("--split", choices=("train", "test"), required=True)
    d.add_argument("--data", required=True, help="nhnet-datagen output directory")
    d.add_argument("--out", required=True)
    d.add_argument("--methods", default=",".join(METHODS))
    d.add_argument("--threads", type=int, default=0)
    f = sub.add_parser("fit", help="fit every method's weights on the training split")
    f.add_argument("feat")
    f.add_argument("--write", required=True)
    f.add_argument("--epochs", type=int, default=300)
    f.add_argument("--seed", type=int, default=0)
    f.add_argument("--threads", type=int, default=2)
    r = sub.add_parser("report", help="AUROC and reliability on the test split")
    r.add_argument("feat")
    r.add_argument("--methods", default=",".join(METHODS))
    c = sub.add_parser("check", help="the pipeline's confidence on whole clouds (.gt.xyzn)")
    c.add_argument("clouds", nargs="+")
    c.add_argument("--method", default="nhnet", choices=METHODS)
    c.add_argument("--threads", type=int, default=0)
    a = ap.parse_args(argv)
    return {"data": cmd_data, "fit": cmd_fit, "report": cmd_report, "check": cmd_check}[a.cmd](a)


if __name__ == "__main__":
    sys.exit(main())
