#!/usr/bin/env python3
"""Fits NH-Net's learned weighted jet fit (core/src/learned/learned_fit.cpp, learned_fit_weights.inc).

Three steps; `data` is resumable (a cloud's file is written once, atomically):

    # neighbourhoods of generated clouds with the default pipeline's normals before the fit
    # (training split: every cloud, cut to 20 000 points, 1000 points each; test split: 4000)
    PYTHONPATH=build/python:training /usr/bin/python3 tools/fit_learned_fit.py data \\
        --split train --every-cloud --rows 1000 --out runs/lfit/train
    PYTHONPATH=build/python:training /usr/bin/python3 tools/fit_learned_fit.py data \\
        --split benchmark --per-category 8 --out runs/lfit/benchmark
    # fit on the training split only (a tenth of its points held out), write the C++ weights
    /usr/bin/python3 tools/fit_learned_fit.py fit runs/lfit/train \\
        --write core/src/learned/learned_fit_weights.inc
    # per category: RMS, mean, PGP5, PGP10, share over 30 deg of the input and the fit
    PYTHONPATH=training /usr/bin/python3 tools/fit_learned_fit.py report runs/lfit/benchmark \\
        --weights core/src/learned/learned_fit_weights.inc

The network and the fit are core/include/nhnet/learned/learned_fit.hpp's; LearnedFit.forward
is what learned_fit.cpp computes. The loss is the mean squared angle error (RMS). The data
generator needs the generated data of `nhnet-datagen --set all` (training/README.md).
"""
from __future__ import annotations

import argparse
import json
import re
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fit_candidate_mix import load_cloud, pick_clouds, unit, write_atomic  # noqa: E402

MEMBERS, FEATURES, GATE_HIDDEN = 64, 7, 16  # MEMBERS: learned_fit.hpp's kFitMembers


def spread(k: int, m: int):
    """Distance ranks of m members spread over k (core/src/util/spread.hpp spread_rank)."""
    if m >= k:
        return np.arange(k)
    return (np.arange(m) * (k - 1) + (m - 1) // 2) // (m - 1)


def data_clouds(a) -> list:
    data_dir = Path(a.data_dir)
    if a.split == "train" and a.every_cloud:
        return json.loads((data_dir / "train" / "index.json").read_text())["clouds"]
    clouds = pick_clouds(data_dir, a.split)
    if a.split == "train" or not a.per_category:
        return clouds
    by = {}
    for c in clouds:
        by.setdefault(c["category"], []).append(c)
    return [c for cs in by.values() for c in cs[::max(1, len(cs) // a.per_category)][:a.per_category]]


def cloud_data(a, c: dict) -> dict:
    """Members (spread over max(--support x k, --members) nearest), their offsets and normals, of
    sampled points of cloud c, with the default pipeline's normals before the learned fit."""
    import nhnet
    from scipy.spatial import cKDTree
    # cut to the benchmark's density (bench/nhnet_bench.py FULL_POINTS)
    xyz, gt, rows = load_cloud(Path(a.data_dir), a.split, c, cut=True)
    rows = rows[::max(1, len(rows) // a.rows)][:a.rows]
    r = nhnet.estimate(xyz, method="nhnet", orient=None, threads=a.threads, learned_fit=False,
                       refine=a.refine)
    n0, k = np.asarray(r.normals), int(r.k_used)
    reach = max(int(round(a.support * k)), a.members)
    _, nb = cKDTree(xyz).query(xyz[rows], k=min(reach, len(xyz)))
    nb = nb[:, spread(nb.shape[1], a.members)]
    return dict(q=(xyz[nb] - xyz[rows][:, None]).astype(np.float32),
                nn=n0[nb].astype(np.float32), n0=n0[rows], gt=unit(gt[rows]),
                noise=float(r.noise_ratio), k=k, cat=c.get("category", ""),
                level=c["noise_percent"], variant=c["variant"], name=c["name"])


def cmd_data(a) -> int:
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for c in data_clouds(a):
        f = out / f"{c['name']}.npz"
        if f.exists():
            continue
        t0 = time.time()
        tmp = out / f"{c['name']}.tmp.npz"
        np.savez(tmp, **cloud_data(a, c))
        tmp.replace(f)
        print(c["name"], f"{time.time() - t0:.1f} s", flush=True)
    return 0


def load_dir(d: str, torch):
    """Tensors of every data file in d: member offsets, member normals, input normals, truths,
    log noise ratios, cloud ids; and each cloud's category, noise level and variant."""
    zs = [np.load(f) for f in sorted(Path(d).glob("*.npz")) if not f.name.endswith(".tmp.npz")]
    cat = lambda key: np.concatenate([z[key] for z in zs])
    noise = np.concatenate([np.full(len(z["n0"]), np.log(max(float(z["noise"]), 1e-4))) for z in zs])
    cid = np.concatenate([np.full(len(z["n0"]), i) for i, z in enumerate(zs)])
    t = [torch.from_numpy(v.astype(np.float32)) for v in
         (cat("q"), cat("nn"), cat("n0"), unit(cat("gt")), noise)]
    meta = [dict(category=str(z["cat"]), noise=float(z["level"]), variant=str(z["variant"]))
            for z in zs]
    return (*t, cid, meta)


def make_fit(torch, hidden: int, ridge: float, tilt: bool = False, degree: int = 2,
             offsets: float = 0.0):
    """LearnedFit. Experiments, not in the C++: `tilt` adds two member features (the tilt of the
    member's normal, oriented like the point's, towards or away from the point, and the size of
    its sideways tilt); `degree` 3 fits a cubic jet; `offsets` > 0 lets the network move each
    member's height by `offsets` times a second output before the fit (AdaFit's idea)."""
    nn = torch.nn
    features = FEATURES + (2 if tilt else 0)

    def axes(n):
        e = torch.where(n[:, :1].abs() < 0.9, torch.tensor([1.0, 0, 0]).expand_as(n),
                        torch.tensor([0, 1.0, 0]).expand_as(n))
        a = nn.functional.normalize(torch.linalg.cross(n, e), dim=1)
        return a, torch.linalg.cross(n, a)

    class LearnedFit(nn.Module):
        def __init__(self):
            super().__init__()
            self.ridge = ridge
            self.tilt = tilt
            self.l1, self.l2 = nn.Linear(features, hidden), nn.Linear(hidden, hidden)
            self.l3, self.l4 = nn.Linear(2 * hidden, hidden), nn.Linear(hidden, 2 if offsets else 1)
            self.g1, self.g2 = nn.Linear(hidden + 1, GATE_HIDDEN), nn.Linear(GATE_HIDDEN, 1)

        def forward(self, q, nn_, n0, noise):
            a, b = axes(n0)
            r = q.norm(dim=2).amax(1).clamp_min(1e-12)[:, None]
            u, v, h = ((q * d[:, None]).sum(2) / r for d in (a, b, n0))
            c = (nn_ * n0[:, None]).sum(2).abs()
            rank = torch.linspace(0, 1, q.shape[1]).expand_as(u)
            rho = torch.sqrt((u * u + v * v).clamp_min(1e-30))  # finite gradient at the point
            cols = [rho, 10 * (h - h.mean(1, keepdim=True)).abs(), 10 * h.abs(), 1 - c, c, rank,
                    noise[:, None].expand_as(u)]
            if self.tilt:
                sign = torch.sign((nn_ * n0[:, None]).sum(2))
                na, nb = ((nn_ * d[:, None]).sum(2) * sign for d in (a, b))
                rho = rho.clamp_min(1e-6)
                cols += [10 * (na * u + nb * v) / rho, 10 * (nb * u - na * v).abs() / rho]
            f = torch.stack(cols, 2)
            e = torch.relu(self.l2(torch.relu(self.l1(f))))
            pooled = e.amax(1)
            out = self.l4(torch.relu(self.l3(torch.cat([e, pooled[:, None].expand_as(e)], 2))))
            w = nn.functional.softplus(out[..., 0])
            if offsets:
                h = h + offsets * out[..., 1]
            terms = [torch.ones_like(u), u, v, u * u, u * v, v * v]
            if degree == 3:
                terms += [u * u * u, u * u * v, u * v * v, v * v * v]
            A = torch.stack(terms, 2)
            atw = A.transpose(1, 2) * w[:, None]
            lhs = atw @ A + self.ridge * w.sum(1)[:, None, None] * torch.eye(len(terms))
            coef = torch.linalg.solve(lhs, atw @ h[..., None])[..., 0]
            fitted = nn.functional.normalize(n0 - coef[:, 1:2] * a - coef[:, 2:3] * b, dim=1)
            gate = torch.sigmoid(self.g2(torch.relu(self.g1(torch.cat([pooled, noise[:, None]], 1)))))
            return nn.functional.normalize(n0 + gate * (fitted - n0), dim=1)

    return LearnedFit()


def experiment_fit(torch, a):
    """The fit that `fit`'s options ask for: the C++'s LearnedFit, or an experiment (make_fit's,
    or --passes fits in a row, each after the first taking the one before's normal as the
    point's normal: its frame and the members' agreement)."""
    def one():
        return make_fit(torch, a.hidden, a.ridge, a.tilt, a.degree, a.offsets)
    if a.passes == 1:
        return one()

    class Passes(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.fits = torch.nn.ModuleList(one() for _ in range(a.passes))

        def forward(self, q, nn_, n0, noise):
            for f in self.fits:
                n0 = f(q, nn_, n0, noise)
            return n0

    return Passes()


def angle(torch, a, b):
    """Unoriented angle between unit rows, radians (atan2 form, as the C++)."""
    return torch.atan2(torch.linalg.cross(a, b).norm(dim=1), (a * b).sum(1).abs())


def cmd_fit(a) -> int:
    import torch
    torch.manual_seed(a.seed)
    torch.set_num_threads(a.threads)
    q, nn_, n0, gt, noise, cid, meta = load_dir(a.data, torch)
    # The smooth analytic shapes weigh more: few clouds, but where the network's denoising beats
    # every fit, so the gate must learn to keep it (as the candidate mix's fit does with them).
    weight = torch.from_numpy(np.array([a.analytic_weight if m["category"] == "Analytic" else 1.0
                                        for m in meta], dtype=np.float32)[cid])
    perm = torch.randperm(len(n0))
    val, train = perm[:len(n0) // 10], perm[len(n0) // 10:]
    m = experiment_fit(torch, a)
    opt = torch.optim.Adam(m.parameters(), lr=a.lr)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, a.epochs)
    best, t0 = float("inf"), time.time()
    for e in range(a.epochs):
        p = train[torch.randperm(len(train))]
        for b in range(0, len(p), a.batch):
            j = p[b:b + a.batch]
            err = angle(torch, m(q[j], nn_[j], n0[j], noise[j]), gt[j])
            loss = (err ** 2 * weight[j]).sum() / weight[j].sum()
            opt.zero_grad()
            loss.backward()
            opt.step()
        sched.step()
        with torch.no_grad():
            err = torch.cat([angle(torch, m(q[j], nn_[j], n0[j], noise[j]), gt[j])
                             for j in val.split(8192)])
        rms, rms0 = (np.degrees(float(x.pow(2).mean().sqrt())) for x in (err, angle(torch, n0[val], gt[val])))
        print(f"epoch {e}: validation RMS {rms:.3f} deg (input {rms0:.3f}), {time.time() - t0:.0f} s",
              flush=True)
        if rms < best:
            best, state = rms, {k: v.clone() for k, v in m.state_dict().items()}
    m.load_state_dict(state)
    print(f"best validation RMS {best:.3f} deg, {len(n0)} points")
    if a.write:
        tried = [f"--{n}" for n, on in (("passes", a.passes != 1), ("tilt", a.tilt),
                                         ("degree", a.degree != 2), ("offsets", a.offsets)) if on]
        if tried:
            sys.exit(f"fit: {' '.join(tried)}: experiments the C++ does not compute: not written")
        if q.shape[1] != MEMBERS:
            sys.exit(f"fit: {a.data} has {q.shape[1]} members per point; the C++ fit takes "
                     f"{MEMBERS} (learned_fit.hpp kFitMembers): not written")
        write_inc(m, Path(a.write), a)
    return 0


def fmt(v) -> str:
    return "{" + ", ".join(f"{float(t):.9g}f" for t in np.ravel(v)) + "}"


def write_inc(m, path: Path, a) -> None:
    p = {k: v.detach().numpy() for k, v in m.state_dict().items()}
    h = a.hidden
    mat = lambda name, rows, cols: (f"constexpr float {name}[{rows}][{cols}] = {{\n    "
                                    + ",\n    ".join(fmt(r) for r in p[name_of[name]]) + "};")
    name_of = {"kW1": "l1.weight", "kW2": "l2.weight", "kW3": "l3.weight", "kG1": "g1.weight"}
    text = f"""// Written by tools/fit_learned_fit.py (fit {a.data} --hidden {h} --ridge {a.ridge} --epochs {a.epochs} --seed {a.seed} --analytic-weight {getattr(a, 'analytic_weight', 1)});
// do not edit. Weights of the learned weighted jet fit (learned_fit.hpp), fitted on the training
// split; matrices are out x in (torch's layout).
// clang-format off
constexpr int kFitHidden = {h};
constexpr int kFitFeatures = {FEATURES};
constexpr int kFitGateHidden = {GATE_HIDDEN};
constexpr double kFitRidge = {a.ridge!r};
{mat("kW1", h, FEATURES)}
constexpr std::array<float, {h}> kB1 = {fmt(p["l1.bias"])};
{mat("kW2", h, h)}
constexpr std::array<float, {h}> kB2 = {fmt(p["l2.bias"])};
{mat("kW3", h, 2 * h)}
constexpr std::array<float, {h}> kB3 = {fmt(p["l3.bias"])};
constexpr std::array<float, {h}> kW4 = {fmt(p["l4.weight"])};
constexpr float kB4 = {float(p["l4.bias"][0]):.9g}f;
{mat("kG1", GATE_HIDDEN, h + 1)}
constexpr std::array<float, {GATE_HIDDEN}> kGB1 = {fmt(p["g1.bias"])};
constexpr std::array<float, {GATE_HIDDEN}> kG2 = {fmt(p["g2.weight"])};
constexpr float kGB2 = {float(p["g2.bias"][0]):.9g}f;
// clang-format on
"""
    write_atomic(path, text)


def read_inc(path: Path, torch):
    """The network back from a .inc file (report on exactly what the C++ runs)."""
    text = path.read_text()
    num = lambda name: re.search(rf"{name} = ([^;]+);", text).group(1)
    m = make_fit(torch, int(num("kFitHidden")), float(num("kFitRidge")))

    def arr(name):
        body = re.search(rf"{name}(?:\[\d+\])* = (\{{.*?\}});", text, re.S)
        body = body.group(1) if body else num(name)
        return torch.tensor([float(t.rstrip("f")) for t in re.sub(r"[{}\s]", "", body).split(",") if t])
    with torch.no_grad():
        for layer, (wn, bn) in {m.l1: ("kW1", "kB1"), m.l2: ("kW2", "kB2"), m.l3: ("kW3", "kB3"),
                                m.l4: ("kW4", "kB4"), m.g1: ("kG1", "kGB1"),
                                m.g2: ("kG2", "kGB2")}.items():
            layer.weight.copy_(arr(wn).reshape(layer.weight.shape))
            layer.bias.copy_(arr(bn).reshape(layer.bias.shape))
    return m


def cmd_report(a) -> int:
    import torch
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "training"))
    from nhnet_training.evaluate import report
    from nhnet_training.metrics import angle_stats
    torch.set_num_threads(a.threads)
    q, nn_, n0, gt, noise, cid, meta = load_dir(a.data, torch)
    m = read_inc(Path(a.weights), torch)
    with torch.no_grad():
        fitted = torch.cat([m(q[j], nn_[j], n0[j], noise[j]) for j in torch.arange(len(n0)).split(8192)])
    rows = []
    for i, mt in enumerate(meta):
        s = torch.from_numpy(cid == i)
        rows.append(dict(mt, input=angle_stats(np.degrees(angle(torch, n0[s], gt[s]).numpy())),
                         fit=angle_stats(np.degrees(angle(torch, fitted[s], gt[s]).numpy()))))
    print(report(rows, ["input", "fit"]))
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    d = sub.add_parser("data")
    d.add_argument("--split", choices=["train", "benchmark", "analytic"], required=True,
                   help="analytic: fit_candidate_mix.py's smooth shapes (its `analytic` step)")
    d.add_argument("--out", required=True)
    d.add_argument("--data-dir", default="data/generated")
    d.add_argument("--every-cloud", action="store_true",
                   help="training split: every cloud, not three levels per model")
    d.add_argument("--per-category", type=int, default=0, help="test split: clouds per category")
    d.add_argument("--rows", type=int, default=4000, help="sampled points per cloud")
    d.add_argument("--members", type=int, default=MEMBERS,
                   help=f"members per point (default {MEMBERS}, the C++'s; others: fit and "
                        "report only, an experiment)")
    d.add_argument("--refine", default="auto", choices=["auto", "all", "moved"],
                   help="the pipeline's refine mode before the fit (default: the core's auto)")
    d.add_argument("--support", type=float, default=1.0,
                   help="members spread over this times the noise-driven k (default 1, the "
                        "C++'s; others: fit and report only, an experiment)")
    f = sub.add_parser("fit")
    f.add_argument("data")
    f.add_argument("--write", default="")
    f.add_argument("--hidden", type=int, default=32)
    f.add_argument("--ridge", type=float, default=1e-3)
    f.add_argument("--epochs", type=int, default=12)
    f.add_argument("--batch", type=int, default=256)
    f.add_argument("--lr", type=float, default=1e-3)
    f.add_argument("--seed", type=int, default=0)
    f.add_argument("--tilt", action="store_true",
                   help="experiment: two more member features (make_fit); reports validation only")
    f.add_argument("--passes", type=int, default=1,
                   help="experiment: fits in a row (experiment_fit); reports validation only")
    f.add_argument("--degree", type=int, default=2, choices=[2, 3],
                   help="experiment: the jet's degree (make_fit); reports validation only")
    f.add_argument("--offsets", type=float, default=0.0,
                   help="experiment: learned member height offsets of this scale (make_fit); "
                        "reports validation only")
    f.add_argument("--analytic-weight", type=float, default=8.0,
                   help="weight of a point of the analytic split in the loss (others: 1)")
    r = sub.add_parser("report")
    r.add_argument("data")
    r.add_argument("--weights", required=True)
    for p in (d, f, r):
        p.add_argument("--threads", type=int, default=2)
    a = ap.parse_args(argv)
    return {"data": cmd_data, "fit": cmd_fit, "report": cmd_report}[a.cmd](a)


if __name__ == "__main__":
    raise SystemExit(main())
