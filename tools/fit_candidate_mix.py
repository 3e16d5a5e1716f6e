#!/usr/bin/env python3
"""Fits NH-Net's candidate mix (core/src/learned/candidate_mix.cpp, candidate_mix_weights.inc).

Three steps, each resumable (a cloud's data file is written once, atomically):

    # per-point candidates and features of generated clouds (training split: 3 noise levels or
    # density variants per model, cycled; clouds cut to 20 000 points, the benchmark's density)
    PYTHONPATH=build/python:training /usr/bin/python3 tools/fit_candidate_mix.py data \\
        --split train --out runs/mix/train
    PYTHONPATH=build/python:training /usr/bin/python3 tools/fit_candidate_mix.py data \\
        --split benchmark --out runs/mix/benchmark
    # fit on the training split only, write the C++ weights
    /usr/bin/python3 tools/fit_candidate_mix.py fit runs/mix/train \\
        --write core/src/learned/candidate_mix_weights.inc
    # per category and noise level: RMS, mean, PGP5, PGP10, share over 30 degrees
    /usr/bin/python3 tools/fit_candidate_mix.py report runs/mix/benchmark \\
        --weights core/src/learned/candidate_mix_weights.inc

`data` also stores each point's descriptor and frame, so `fit --model M` and `report --model M`
recompute the network's normals for another model of the same descriptor version without a new
`data` run.

Candidates and features are those of core/include/nhnet/learned/candidate_mix.hpp, computed here
from the same core calls the pipeline makes (nhnet.descriptors -> the shipped model, nhnet.estimate
with method mfps and pca); the mix's weights are softmax outputs of a 2-layer tanh network; the
loss is the mean over clouds of each cloud's mean squared angle error (every cloud weighs the
same), so the fit aims at RMS. The data generator needs the generated data of
`nhnet-datagen --set all` (training/README.md).
"""
from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

import numpy as np

FEATURES, CANDIDATES, HIDDEN, NEIGHBOURS = 24, 8, 32, 16
LEVEL_CYCLE = [(0.0, "uniform"), (0.1, "uniform"), (0.3, "uniform"), (0.6, "uniform"),
               (1.2, "uniform"), (0.0, "stripes"), (0.3, "gradient"), (0.5, "uniform"),
               (0.05, "uniform"), (0.2, "uniform"), (0.4, "uniform"), (0.0, "gradient"),
               (0.3, "stripes")]


def unit(a):
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


def angle(a, b):
    """Unoriented angle between unit rows, radians (atan2 form, as the C++)."""
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.abs(np.sum(a * b, -1)))


def slerp(a, b, w):
    """Unit rows a rotated towards sign-aligned b by fraction w (mfps_blend.cpp slerp_towards)."""
    b = np.where(np.sum(a * b, 1, keepdims=True) < 0, -b, b)
    th = np.arccos(np.clip(np.sum(a * b, 1), -1, 1))
    out, m = a.copy(), th > 1e-9
    s = np.sin(th[m])[:, None]
    out[m] = (np.sin((1 - w[m]) * th[m])[:, None] * a[m] + np.sin(w[m] * th[m])[:, None] * b[m]) / s
    return unit(out)


ANALYTIC = [(shape, 20000, level) for shape in ("sphere", "ellipsoid", "torus")
            for level in (0.0, 0.3, 0.6, 1.2)] + [("sphere", 5000, 0.6), ("ellipsoid", 5000, 0.3)]


def analytic_surface(shape: str, n: int, rng):
    """n points uniform by area on a smooth closed shape, and their exact unit normals."""
    pts, nrm = np.zeros((0, 3)), np.zeros((0, 3))
    while len(pts) < n:
        if shape == "torus":  # R = 1, r = 0.35; area density (R + r cos v) by rejection
            u, v = rng.uniform(0, 2 * np.pi, (2, 4 * n))
            keep = rng.uniform(0, 1.35, 4 * n) < 1 + 0.35 * np.cos(v)
            u, v = u[keep], v[keep]
            c = np.stack([np.cos(u), np.sin(u), 0 * u], 1)
            q = np.stack([np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)], 1)
            p, m = c + 0.35 * q, q
        else:  # sphere, or ellipsoid (1, 0.6, 0.35) by rejection on the sphere's map
            axes = np.array([1.0, 1.0, 1.0] if shape == "sphere" else [1.0, 0.6, 0.35])
            d = unit(rng.normal(size=(4 * n, 3)))
            g = d / axes  # normal direction of the mapped point, unnormalised
            area = np.linalg.norm(g, axis=1) * np.prod(axes)
            keep = rng.uniform(0, area.max(), 4 * n) < area
            p, m = d[keep] * axes, unit(g[keep])
        pts, nrm = np.vstack([pts, p]), np.vstack([nrm, m])
    return pts[:n], nrm[:n]


def analytic_clouds():
    """Every ANALYTIC cloud (shape, points, noise %, noisy points, true normals), each from its
    own fixed seed: the same clouds on every call."""
    for i, (shape, n, level) in enumerate(ANALYTIC):
        rng = np.random.default_rng(100 + i)
        pts, nrm = analytic_surface(shape, n, rng)
        diag = np.linalg.norm(pts.max(0) - pts.min(0))
        yield shape, n, level, pts + rng.normal(scale=level / 100 * diag, size=pts.shape), nrm


def cmd_analytic(a) -> int:
    """Smooth closed shapes for the mix's training data (split "analytic"): the mesh models are
    organic but thin-limbed, and a mix fitted on them alone under-trusts the network on broad
    smooth surfaces, where its denoising beats every fit."""
    out = Path(a.out) / "analytic"
    out.mkdir(parents=True, exist_ok=True)
    clouds = []
    for shape, n, level, pts, nrm in analytic_clouds():
        name = f"{shape}_{n}_noise{level:g}"
        np.savetxt(out / f"{name}.xyz", pts, fmt="%.8f")
        np.savetxt(out / f"{name}.normals", nrm, fmt="%.8f")
        np.savetxt(out / f"{name}.gt.xyzn", np.hstack([pts, nrm]), fmt="%.8f")  # nhnet-cli eval
        clouds.append(dict(name=name, model=shape, category="Analytic", noise_percent=level,
                           variant="uniform", files=[f"{name}.xyz", f"{name}.normals"]))
    (out / "index.json").write_text(json.dumps({"clouds": clouds}, indent=1))
    print(f"{len(clouds)} clouds in {out}")
    return 0


def pick_clouds(data_dir: Path, split: str):
    idx = json.loads((data_dir / split / "index.json").read_text())["clouds"]
    if split != "train":
        return idx
    models, out = sorted({c["model"] for c in idx}), []
    for r in range(3):  # the first level of every model, then the second, then the third
        for i, m in enumerate(models):
            lv = LEVEL_CYCLE[(i + 4 * r) % len(LEVEL_CYCLE)]
            out += [c for c in idx if c["model"] == m and (c["noise_percent"], c["variant"]) == lv]
    return out


def inconsistency(n, rows, nb):
    return 1 - np.abs(np.einsum("nj,nkj->nk", n[rows], n[nb])).mean(1)


def half_k(k: int) -> int:
    """Neighbourhood of the half-scale PCA candidate (geometry/jet.hpp kHalfScaleMin)."""
    return max(6, k // 2)


def covariance_eig(xyz, nb):
    """Centroids of neighbourhoods nb (M x k) and their covariances' eigenvalues (ascending, of
    the scatter, not divided by k) and eigenvectors (columns), as geometry/pca.cpp's fit_plane."""
    c = xyz[nb].mean(1)
    q = xyz[nb] - c[:, None]
    w, v = np.linalg.eigh(np.einsum("nki,nkj->nij", q, q))
    return c, w, v


def pca_rows(eig):
    """PCA normals and surface variations from covariance_eig()."""
    _, w, v = eig
    return v[:, :, 0], np.maximum(w[:, 0], 0) / w.sum(1)


def jet_rows(xyz, rows, nb, frame):
    """Quadratic height fit over nb in the frame of the PCA normal (geometry/jet.hpp)."""
    out = np.empty((len(rows), 3))
    for i, (r, ids) in enumerate(zip(rows, nb)):
        q, n = xyz[ids] - xyz[r], frame[i]
        a = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
        a /= np.linalg.norm(a)
        b = np.cross(n, a)
        u, v, h = q @ a, q @ b, q @ n
        s = np.sqrt((u * u + v * v).mean()) + 1e-300
        u, v = u / s, v / s
        c = np.linalg.lstsq(np.stack([np.ones_like(u), u, v, u * u, u * v, v * v], 1), h / s,
                            rcond=None)[0]
        out[i] = unit(n - c[1] * a - c[2] * b)
    return out


def radial_rows(xyz, rows, eig, k: int):
    """Radial normals (geometry/radial.hpp) from covariance_eig() of k-point neighbourhoods: the
    point's offset from the centroid without its part along the principal direction, its length
    over the RMS spread, and the middle over the largest eigenvalue."""
    c, w, v = eig
    w = np.maximum(w, 0)
    d = xyz[rows] - c
    r = d - np.sum(d * v[:, :, 2], 1, keepdims=True) * v[:, :, 2]
    length, spread = np.linalg.norm(r, axis=1), np.sqrt(w.sum(1) / k)
    length = np.where((spread > 0) & (length > 1e-9 * spread), length, np.nan)  # radial.cpp
    with np.errstate(divide="ignore", invalid="ignore"):
        return r / length[:, None], length / spread, w[:, 1] / w[:, 2]


def geometric_candidates(xyz, rows, pca, k: int) -> dict:
    """The mix's candidates that need no network: jet at k, PCA at half_k(k), radial at both."""
    from scipy.spatial import cKDTree
    tree = cKDTree(xyz)
    _, nb = tree.query(xyz[rows], k=min(k, len(xyz)))
    _, nbh = tree.query(xyz[rows], k=min(half_k(k), len(xyz)))
    eig_half = covariance_eig(xyz, nbh)
    half, var_half = pca_rows(eig_half)
    radk, offk, elk = radial_rows(xyz, rows, covariance_eig(xyz, nb), nb.shape[1])
    radh, offh, elh = radial_rows(xyz, rows, eig_half, nbh.shape[1])
    return dict(k=k, jet=jet_rows(xyz, rows, nb, pca[rows]), half=half, var_half=var_half,
                radk=radk, radh=radh, offk=offk, offh=offh, elk=elk, elh=elh)


def load_cloud(data_dir: Path, split: str, c: dict, cut: bool = False):
    """A cloud, its true normals and 4000 sampled rows. Training clouds are cut to 20 000 points
    (fixed seed); `cut` cuts the other splits too (the benchmark's density, the learned fit's
    data) - the mix's own test data stays whole."""
    xyz = np.loadtxt(data_dir / split / c["files"][0], ndmin=2)
    gt = np.loadtxt(data_dir / split / c["files"][1], ndmin=2)
    if (split == "train" or cut) and len(xyz) > 20000:
        keep = np.sort(np.random.default_rng(11).choice(len(xyz), 20000, replace=False))
        xyz, gt = xyz[keep], gt[keep]
    rows = np.sort(np.random.default_rng(7).choice(len(xyz), min(4000, len(xyz)), replace=False))
    return xyz, gt, rows


def cloud_data(data_dir: Path, split: str, c: dict, model, threads: int) -> dict:
    """model: (TorchScript module, its descriptor version), as nhnet_training's model_and_version."""
    import nhnet
    from scipy.spatial import cKDTree

    xyz, gt, rows = load_cloud(data_dir, split, c)
    model, version = model
    d = nhnet.descriptors(xyz, threads=threads, version=version)
    bl = np.asarray(nhnet.estimate(xyz, method="mfps", orient=None, threads=threads).normals)
    p = nhnet.estimate(xyz, method="pca", orient=None, threads=threads)
    desc = d["features"][rows].astype(np.float32)
    desc[~d["valid"][rows]] = np.nan  # no descriptor: the network keeps the MFPS normal
    rot = d["rotations"][rows]
    un, pca = d["normals"], np.asarray(p.normals)
    _, nb = cKDTree(xyz).query(xyz[rows], k=NEIGHBOURS)
    return dict(net=net_normals(model, desc, rot, un[rows]), desc=desc, rot=rot,
                desc_version=version, un=un[rows], bl=bl[rows], pca=pca[rows], gt=gt[rows],
                xyz=xyz[rows],
                curv=np.asarray(p.curvature)[rows], noise=d["noise_ratio"],
                inc_pca=inconsistency(pca, rows, nb), inc_bl=inconsistency(bl, rows, nb),
                inc_un=inconsistency(un, rows, nb), name=c["name"],
                cat=c.get("category", ""), level=c["noise_percent"], variant=c["variant"],
                **geometric_candidates(xyz, rows, pca, int(p.k_used)))


def net_normals(model, desc, rot, un):
    """The network's world-frame normals (R^T y) from descriptors `desc` and their frames `rot`;
    the MFPS normal `un` where a row has no descriptor (NaN), as the pipeline keeps it."""
    import torch

    ok = np.isfinite(desc).all(1)
    with torch.no_grad():
        local = model(torch.from_numpy(np.nan_to_num(desc).astype(np.float32))).double().numpy()
    return unit(np.where(ok[:, None], np.einsum("nji,nj->ni", rot, local), un))


def with_model(z, model):
    """Data file z with the network column recomputed by `model` (module, descriptor version)
    from its stored descriptors: one `data` run serves every model of that descriptor version."""
    module, version = model
    if "desc" not in z:
        raise SystemExit(f"{z['name']}: written before the descriptors were stored: run `data` "
                         "again to use --model")
    if int(z["desc_version"]) != version:
        raise SystemExit(f"{z['name']}: descriptors of version {int(z['desc_version'])}, the "
                         f"model reads version {version}")
    z = dict(z)
    z["net"] = net_normals(module, z["desc"], z["rot"], z["un"])
    return z


def same_points(z: dict, xyz, gt, rows) -> bool:
    """Whether data file z holds the points `rows` of the cloud: by their coordinates where it
    stored them, else by their true normals (files written before it stored them)."""
    if "xyz" in z:
        return z["xyz"].shape == xyz[rows].shape and np.allclose(z["xyz"], xyz[rows])
    return z["gt"].shape == gt[rows].shape and np.allclose(unit(z["gt"]), unit(gt[rows]))


def check_points(f: Path, c: dict, xyz, gt, rows) -> None:
    """Refuses a data file whose points are not the cloud's rows as load_cloud picks them now
    (the generated cloud or the sampling changed since it was written): its candidates would
    be paired with another point's true normal."""
    if not same_points(np.load(f), xyz, gt, rows):
        raise SystemExit(f"{f}: not the points of {c['name']} that load_cloud picks now (the "
                         "cloud or the sampling changed): delete it and run `data` again")


def extend(f: Path, xyz, rows, threads: int) -> None:
    """Adds the geometric candidates to a data file written before they existed (no network)."""
    import nhnet
    z = dict(np.load(f))
    p = nhnet.estimate(xyz, method="pca", orient=None, threads=threads)
    z.update(geometric_candidates(xyz, rows, np.asarray(p.normals), int(p.k_used)))
    tmp = f.with_name(f.stem + ".tmp.npz")
    np.savez(tmp, **z)
    tmp.replace(f)


def cmd_data(a) -> int:
    import torch
    torch.set_num_threads(a.threads)
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "training"))
    from nhnet_training.evaluate import model_and_version

    model = model_and_version(a.model)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for c in pick_clouds(Path(a.data_dir), a.split):
        f = out / f"{c['name']}.npz"
        if f.exists():
            xyz, gt, rows = load_cloud(Path(a.data_dir), a.split, c)
            check_points(f, c, xyz, gt, rows)
            if "radk" not in np.load(f):
                extend(f, xyz, rows, a.threads)
                print(c["name"], "extended", flush=True)
            continue
        tmp = out / f"{c['name']}.tmp.npz"
        np.savez(tmp, **cloud_data(Path(a.data_dir), a.split, c, model, a.threads))
        tmp.replace(f)
        print(c["name"], flush=True)
    return 0


def features_and_candidates(z, refine="all"):
    """The C++ mix_row(): features (M x FEATURES) and sign-aligned candidates (M x 8 x 3). With
    refine="moved" the network runs only where MFPS moved the PCA normal (refine.cpp,
    ModelOptions::refine = Refine::Moved): elsewhere net = un."""
    un, bl, pca, jet, half = (unit(z[k]) for k in ("un", "bl", "pca", "jet", "half"))
    moved = (un != pca).any(1)
    net = np.where(moved[:, None] | (refine == "all"), unit(z["net"]), un)
    a_up = angle(un, pca)
    w = np.where(a_up > 1e-6, np.clip(angle(un, bl) / np.maximum(a_up, 1e-12), 0, 1), 0)
    radk, radh = (np.where(np.isfinite(z[r]).all(1, keepdims=True), z[r], pca)
                  for r in ("radk", "radh"))
    cand = np.stack([net, slerp(net, pca, w), pca, bl, jet, half, radk, radh], 1)
    cand *= np.where(np.sum(cand * net[:, None], -1, keepdims=True) < 0, -1, 1)
    f = np.stack([angle(net, pca), angle(net, bl), angle(pca, bl), angle(net, un), w,
                  moved.astype(float), np.full(len(w), np.log(max(float(z["noise"]), 1e-4))),
                  np.sqrt(np.clip(z["curv"], 0, 1)), z["inc_pca"], z["inc_bl"], z["inc_un"],
                  angle(jet, net), angle(jet, pca), angle(half, net), angle(half, pca),
                  np.sqrt(np.clip(z["var_half"], 0, 1)),
                  angle(radk, net), angle(radk, pca), angle(radh, net), angle(radh, pca),
                  *(np.nan_to_num(z[r], nan=0.0, posinf=0.0)
                    for r in ("offk", "offh", "elk", "elh"))], 1)
    return f, cand


def load_dir(d: str, refine: str = "all", model=None):
    """Features, candidates, truths, cloud ids and cloud names of every data file in d; with
    `model` (with_model), its network normals instead of the stored ones."""
    X, C, G, cid, meta = [], [], [], [], []
    for i, f in enumerate(sorted(Path(d).glob("*.npz"))):
        if f.name.endswith(".tmp.npz"):
            continue
        z = np.load(f)
        z = with_model(z, model) if model else z
        x, c = features_and_candidates(z, refine)
        g = unit(z["gt"])
        ok = np.isfinite(x).all(1) & np.isfinite(c).all((1, 2)) & np.isfinite(g).all(1)
        X.append(x[ok]), C.append(c[ok]), G.append(g[ok]), cid.append(np.full(ok.sum(), len(meta)))
        meta.append(dict(name=str(z["name"]), category=str(z["cat"]), noise=float(z["level"]),
                         variant=str(z["variant"])))
    return np.concatenate(X), np.concatenate(C), np.concatenate(G), np.concatenate(cid), meta


def make_mix(torch):
    class Mix(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.l1 = torch.nn.Linear(FEATURES, HIDDEN)
            self.l2 = torch.nn.Linear(HIDDEN, HIDDEN)
            self.l3 = torch.nn.Linear(HIDDEN, CANDIDATES)
            self.register_buffer("mean", torch.zeros(FEATURES, dtype=torch.float64))
            self.register_buffer("scale", torch.ones(FEATURES, dtype=torch.float64))

        def forward(self, x, c):
            h = torch.tanh(self.l1((x - self.mean) / self.scale))
            w = torch.softmax(self.l3(torch.tanh(self.l2(h))), -1)
            n = (w[..., None] * c).sum(1)
            return n / n.norm(dim=-1, keepdim=True).clamp_min(1e-12)
    return Mix().double()


def given_model(a):
    """(module, descriptor version) of --model, or None (the network normals stored by `data`)."""
    if not a.model:
        return None
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "training"))
    from nhnet_training.evaluate import model_and_version
    return model_and_version(a.model)


def cmd_fit(a) -> int:
    import torch
    torch.manual_seed(a.seed)
    torch.set_num_threads(a.threads)
    X, C, G, cid, meta = load_dir(a.data, a.refine, given_model(a))
    x, c, g = (torch.from_numpy(v) for v in (X, C, G))
    cw = torch.from_numpy(1.0 / np.bincount(cid)[cid])  # every cloud weighs the same
    m = make_mix(torch)
    m.mean.copy_(x.mean(0))
    m.scale.copy_(x.std(0).clamp_min(1e-6))
    opt = torch.optim.Adam(m.parameters(), lr=a.lr)
    for e in range(a.epochs):
        perm, tot = torch.randperm(len(x)), 0.0
        for b in range(0, len(x), a.batch):
            j = perm[b:b + a.batch]
            n = m(x[j], c[j])
            err = torch.atan2(torch.linalg.cross(n, g[j]).norm(dim=-1), (n * g[j]).sum(-1).abs())
            loss = (err ** 2 * cw[j]).sum() / cw[j].sum()
            opt.zero_grad()
            loss.backward()
            opt.step()
            tot += float(loss) * len(j)
        if e % 10 == 0 or e == a.epochs - 1:
            print(f"epoch {e}: training RMS {np.degrees(np.sqrt(tot / len(x))):.3f} deg", flush=True)
    print(f"{len(meta)} clouds, {len(x)} points")
    if a.write:
        write_inc(m, Path(a.write), a)
    return 0


def fmt(v) -> str:
    return "{" + ", ".join(f"{float(t):.9g}" for t in v) + "}"


def write_inc(m, path: Path, a) -> None:
    p = {k: v.detach().numpy() for k, v in m.state_dict().items()}
    rows = lambda w: ",\n    ".join(fmt(r) for r in w)
    model = f" --model {Path(a.model).name}" if a.model else ""
    text = f"""// Written by tools/fit_candidate_mix.py (fit {a.data} --refine {a.refine} --epochs {a.epochs} --seed {a.seed}{model});
// do not edit. Weights of the candidate mix (candidate_mix.hpp), fitted on the training split.
// clang-format off
constexpr std::array<double, kMixFeatures> kMean = {fmt(p['mean'])};
constexpr std::array<double, kMixFeatures> kScale = {fmt(p['scale'])};
constexpr std::array<std::array<double, kMixFeatures>, kMixHidden> kW1 = {{{{
    {rows(p['l1.weight'])}}}}};
constexpr std::array<double, kMixHidden> kB1 = {fmt(p['l1.bias'])};
constexpr std::array<std::array<double, kMixHidden>, kMixHidden> kW2 = {{{{
    {rows(p['l2.weight'])}}}}};
constexpr std::array<double, kMixHidden> kB2 = {fmt(p['l2.bias'])};
constexpr std::array<std::array<double, kMixHidden>, kMixCandidates> kW3 = {{{{
    {rows(p['l3.weight'])}}}}};
constexpr std::array<double, kMixCandidates> kB3 = {fmt(p['l3.bias'])};
// clang-format on
"""
    write_atomic(path, text)


def write_atomic(path: Path, text: str) -> None:
    """Writes text to path through a temporary file and a rename (a weights file is never half
    written)."""
    tmp = path.with_suffix(".tmp")
    tmp.write_text(text)
    tmp.replace(path)
    print(f"wrote {path}")


def read_inc(path: Path, torch):
    """The weights back from a .inc file (report on exactly what the C++ runs)."""
    text = path.read_text()
    m = make_mix(torch)
    def arr(name):
        body = re.search(name + r" = \{(.*?)\};", text, re.S).group(1)
        return torch.tensor([float(t) for t in re.sub(r"[{}\s]", "", body).split(",") if t],
                            dtype=torch.float64)
    with torch.no_grad():
        m.mean.copy_(arr("kMean")), m.scale.copy_(arr("kScale"))
        for layer, (wn, bn) in zip((m.l1, m.l2, m.l3), (("kW1", "kB1"), ("kW2", "kB2"), ("kW3", "kB3"))):
            layer.weight.copy_(arr(wn).reshape(layer.weight.shape))
            layer.bias.copy_(arr(bn))
    return m


def cmd_report(a) -> int:
    import torch
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "training"))
    from nhnet_training.evaluate import report
    from nhnet_training.metrics import angle_stats
    X, C, G, cid, meta = load_dir(a.data, a.refine, given_model(a))
    with torch.no_grad():
        mix = read_inc(Path(a.weights), torch)(torch.from_numpy(X), torch.from_numpy(C)).numpy()
    names = ["net", "net+blend", "pca-auto", "mfps", "jet", "pca-half", "radial", "radial-half",
             "mix", "oracle"]
    rows = []
    for i, mt in enumerate(meta):
        s = cid == i
        r = dict(mt)
        for k, n in enumerate(names[:CANDIDATES]):
            r[n] = angle_stats(np.degrees(angle(C[s, k], G[s])))
        r["mix"] = angle_stats(np.degrees(angle(mix[s], G[s])))
        # the best candidate of each point, known only with the truth: what a perfect chooser gets
        r["oracle"] = angle_stats(np.degrees(angle(C[s], G[s][:, None])).min(1))
        rows.append(r)
    print(report(rows, names))
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    d = sub.add_parser("data")
    d.add_argument("--split", choices=["train", "benchmark", "analytic"], required=True)
    d.add_argument("--out", required=True)
    d.add_argument("--data-dir", default="data/generated")
    d.add_argument("--model", default="models/nhnet.pt")
    d.add_argument("--threads", type=int, default=2)
    f = sub.add_parser("fit")
    f.add_argument("data")
    f.add_argument("--write", default="")
    f.add_argument("--epochs", type=int, default=60)
    f.add_argument("--batch", type=int, default=8192)
    f.add_argument("--lr", type=float, default=3e-3)
    f.add_argument("--seed", type=int, default=0)
    f.add_argument("--threads", type=int, default=2)
    an = sub.add_parser("analytic")
    an.add_argument("--out", default="data/generated")
    r = sub.add_parser("report")
    r.add_argument("data")
    for q in (f, r):
        q.add_argument("--refine", choices=["all", "moved"], default="all",
                       help="where the network runs (ModelOptions::refine All / Moved)")
        q.add_argument("--model", default="",
                       help="recompute the network's normals with this model from the stored "
                            "descriptors (same descriptor version) instead of data's --model")
    r.add_argument("--weights", required=True)
    a = ap.parse_args(argv)
    return {"data": cmd_data, "fit": cmd_fit, "report": cmd_report,
            "analytic": cmd_analytic}[a.cmd](a)


if __name__ == "__main__":
    raise SystemExit(main())
