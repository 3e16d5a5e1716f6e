#!/usr/bin/env python3
"""Fits the MFPS PCA blend (MfpsOptions::pca_blend, core/src/geometry/mfps_blend.cpp kBlendCoefficients).

Input: the files `calibrate_scales blend=DIR ...` writes (one per cloud with ground truth): per
candidate with a rival its blend features, its MFPS normal before the blend, its PCA normal and
the ground truth. The final normal is the MFPS normal rotated towards the PCA normal by
w = logistic(c . t(f)), t(f) = the features and their pairwise products (a quadratic form in
the features); c minimises the sum over clouds of each cloud's mean squared angle error
(degrees^2), i.e. the mean of the per-cloud MSEs, found with L-BFGS (torch autograd).

    python3 tools/fit_mfps_blend.py DIR/*.blend.txt                  # fit, print c and RMS per cloud
    python3 tools/fit_mfps_blend.py --coefficients c0,c1,... FILES   # evaluate given c

Prints the coefficients as a C++ initializer and, per cloud, the whole-cloud RMS angle error
without and with the blend and with the PCA normal in place of every blended candidate.
"""
import argparse
import math
from pathlib import Path

import numpy as np
import torch

FEATURES = 12
TERMS = FEATURES + (FEATURES - 1) * FEATURES // 2


def load(path: Path):
    with open(path) as f:
        header = f.readline().split()
    points, rest_sq = int(header[2]), float(header[4])
    data = np.loadtxt(path, ndmin=2)
    if data.size == 0:
        data = np.zeros((0, 1 + FEATURES + 9))
    t = torch.from_numpy(data).double()
    return {"name": path.name.replace(".blend.txt", ""), "points": points, "rest_sq": rest_sq,
            "f": terms(t[:, 1:1 + FEATURES]), "m": t[:, 1 + FEATURES:4 + FEATURES],
            "p": t[:, 4 + FEATURES:7 + FEATURES], "g": t[:, 7 + FEATURES:10 + FEATURES]}


def terms(f):
    """The blend's terms, in the order of core/src/geometry/mfps_blend.cpp blend_weight(): the features (the
    first is the intercept), then every product f_a f_b of the others with a <= b."""
    products = [f[:, a] * f[:, b] for a in range(1, FEATURES) for b in range(a, FEATURES)]
    return torch.cat([f, torch.stack(products, 1)], 1) if len(f) else f.new_zeros((0, TERMS))


def unit(v):
    return v / v.norm(dim=1, keepdim=True).clamp_min(1e-12)


def slerp(a, b, w):
    """Rotates unit rows a towards unit rows b (sign-aligned) by fraction w of their angle."""
    b = torch.where(((a * b).sum(1, keepdim=True) < 0), -b, b)
    cos = (a * b).sum(1).clamp(-1 + 1e-12, 1 - 1e-12)
    theta = torch.acos(cos)
    small = theta < 1e-6
    st = torch.where(small, torch.ones_like(theta), torch.sin(theta))
    v = (torch.sin((1 - w) * theta)[:, None] * a + torch.sin(w * theta)[:, None] * b) / st[:, None]
    return unit(torch.where(small[:, None], a, v))


def sq_error(e, g):
    """Squared unoriented angle error in degrees^2, per row."""
    c = (unit(e) * g).sum(1).abs().clamp(0, 1 - 1e-12)
    return torch.rad2deg(torch.acos(c)) ** 2


def blended(cloud, c):
    w = torch.sigmoid(cloud["f"] @ c)
    return slerp(unit(cloud["m"]), unit(cloud["p"]), w)


def loss(clouds, c):
    return sum((cloud["rest_sq"] + sq_error(blended(cloud, c), cloud["g"]).sum()) / cloud["points"]
               for cloud in clouds)


def rms(cloud, normals):
    total = cloud["rest_sq"] + float(sq_error(normals, cloud["g"]).sum())
    return math.sqrt(total / cloud["points"])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+", type=Path)
    ap.add_argument("--coefficients", help="evaluate these (comma separated) instead of fitting")
    ap.add_argument("--iterations", type=int, default=300)
    args = ap.parse_args()
    torch.set_default_dtype(torch.float64)
    clouds = [load(p) for p in args.files]
    if args.coefficients:
        c = torch.tensor([float(x) for x in args.coefficients.split(",")])
    else:
        c = torch.zeros(TERMS)
        c[0] = -2.0  # start close to "no blend"
        c.requires_grad_(True)
        opt = torch.optim.LBFGS([c], lr=1, max_iter=args.iterations, history_size=20,
                                line_search_fn="strong_wolfe", tolerance_grad=1e-9,
                                tolerance_change=1e-12)

        def closure():
            opt.zero_grad()
            value = loss(clouds, c)
            value.backward()
            return value

        opt.step(closure)
        c = c.detach()
    print("coefficients: {" + ", ".join(f"{x:.4f}" for x in c.tolist()) + "}")
    with torch.no_grad():
        print(f"{'cloud':32s} {'mfps':>7s} {'blend':>7s} {'pca':>7s}  (whole-cloud RMS, deg)")
        for cloud in clouds:
            print(f"{cloud['name']:32s} {rms(cloud, unit(cloud['m'])):7.2f} "
                  f"{rms(cloud, blended(cloud, c)):7.2f} {rms(cloud, unit(cloud['p'])):7.2f}")
        print(f"objective (sum of per-cloud MSE): {float(loss(clouds, c)):.1f}")


if __name__ == "__main__":
    main()
