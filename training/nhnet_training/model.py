"""NH-Net (paper Sec. 5.2): 9 HMP branches each producing a 3x3 matrix applied to its (rotated)
normal, then a gathering MLP; output L2-normalised, in the canonical frame.

Input: the core's descriptor, (B, D) float32 with D = 3 F + F m^2: F rotated normals then F
m x m height maps (core/include/nhnet/learned/descriptors.hpp). The 9 branches have separate weights,
run as grouped convolutions (one call for all branches)."""
from __future__ import annotations

import math

import torch
import torch.nn as nn
import torch.nn.functional as F

from .config import NUM_NORMALS, PATCH_SIZE, TrainConfig


class NhNet(nn.Module):
    def __init__(self, cfg: TrainConfig, num_normals: int = NUM_NORMALS, patch: int = PATCH_SIZE):
        super().__init__()
        f, c1, c2 = num_normals, cfg.conv1, cfg.conv2
        self.f = f
        self.patch = patch
        self.residual = cfg.residual
        # Branch layout of the authors (conv 3x3 pad 1 -> conv -> maxpool 3 s1 -> conv -> maxpool
        # 3 s1 -> conv to one channel, tanh): 7x7 -> 7x7 -> 5x5 -> 5x5 -> 3x3 = the matrix.
        self.branches = nn.Sequential(
            nn.Conv2d(f, f * c1, 3, padding=1, groups=f), nn.ReLU(),
            nn.Conv2d(f * c1, f * c2, 3, padding=1, groups=f), nn.ReLU(),
            nn.MaxPool2d(3, stride=1),
            nn.Conv2d(f * c2, f * c1, 3, padding=1, groups=f), nn.ReLU(),
            nn.MaxPool2d(3, stride=1),
            nn.Conv2d(f * c1, f, 3, padding=1, groups=f), nn.Tanh(),
        )
        self.gather = nn.Sequential(
            nn.BatchNorm1d(3 * f),
            nn.Linear(3 * f, cfg.hidden1), nn.BatchNorm1d(cfg.hidden1), nn.ReLU(), nn.Dropout(cfg.dropout),
            nn.Linear(cfg.hidden1, cfg.hidden2), nn.BatchNorm1d(cfg.hidden2), nn.ReLU(), nn.Dropout(cfg.dropout),
            nn.Linear(cfg.hidden2, 3),
        )
        if self.residual:
            # Start as the identity on the self normal: the correction's last layer begins at 0.
            nn.init.zeros_(self.gather[-1].weight)
            nn.init.zeros_(self.gather[-1].bias)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        b = x.shape[0]
        normals = x[:, : 3 * self.f].reshape(b, self.f, 3)
        maps = x[:, 3 * self.f:].reshape(b, self.f, self.patch, self.patch)
        mats = self.branches(maps).reshape(b, self.f, 3, 3)
        return head_output(self.gather(transformed(mats, normals)), normals, self.residual)


def transformed(mats: torch.Tensor, normals: torch.Tensor) -> torch.Tensor:
    """Each branch's 3x3 matrix times its normal: (B, F, 3, 3) x (B, F, 3) -> (B, 3F), the
    gathering MLP's input (paper Fig. 3)."""
    return torch.matmul(mats, normals.unsqueeze(-1)).reshape(normals.shape[0], -1)


def head_output(out: torch.Tensor, normals: torch.Tensor, residual: bool) -> torch.Tensor:
    """The gathered vector, plus the self normal when the head is residual, made unit."""
    if residual:
        out = out + normals[:, 0, :]
    return F.normalize(out, dim=1)


def solve3(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Solves a x = b for batches of 3 x 3 matrices (..., 3, 3) by the adjugate (cofactors), which
    TorchScript and every libtorch CPU build run without LAPACK; det is kept away from 0."""
    c0 = torch.cross(a[..., 1, :], a[..., 2, :], dim=-1)
    c1 = torch.cross(a[..., 2, :], a[..., 0, :], dim=-1)
    c2 = torch.cross(a[..., 0, :], a[..., 1, :], dim=-1)
    det = (a[..., 0, :] * c0).sum(-1, keepdim=True)
    det = torch.where(det.abs() < 1e-9, torch.full_like(det, 1e-9), det)
    # inverse = [c0 c1 c2] / det (columns), so x = (c0 b0 + c1 b1 + c2 b2) / det
    x = c0 * b[..., 0:1] + c1 * b[..., 1:2] + c2 * b[..., 2:3]
    return x / det


class NhNetFit(nn.Module):
    """NH-Net v7 candidate (issue 23): NH-Net's candidate choice plus learned weighted plane fits
    over the raw neighbourhood, at more than one scale (the DeepFit/AdaFit family).

    Same input as NhNet (the core's descriptor: F = 9 bilateral-filtered MFPS normals in the
    canonical frame and, for each, the m x m height map of the neighbours around its tangent
    plane, heights in cells), so the C++ inference runs it unchanged (TorchScript, same metadata
    checks). Per map f a small grouped CNN gives one weight per bin and scale (softplus, times a
    Gaussian window of `fit_scales` cells and zero on empty bins); a weighted least-squares plane
    z = p u + q v + c over the bins, solved in closed form, tilts n_f into a fitted normal
    n_f - p x_f - q y_f (x_f, y_f: the map's axes, Gram-Schmidt of the frame's e1, e2 as in
    core/src/learned/height_map.cpp). Head: softmax weights over the F MFPS candidates and the
    F S fits (NhNet's gathered features + the fits as input), started on the self normal, plus
    NhNet's residual correction; an untrained network reproduces MFPS."""

    def __init__(self, cfg: TrainConfig, num_normals: int = NUM_NORMALS, patch: int = PATCH_SIZE):
        super().__init__()
        base = NhNet(cfg, num_normals, patch)  # NhNet's layers under NhNet's names: a v6
        self.branches, self.gather = base.branches, base.gather  # state dict warm-starts them
        f, c, s = num_normals, cfg.fit_channels, len(cfg.fit_scales)
        self.f, self.patch, self.scales = f, patch, s
        self.weigher = nn.Sequential(
            nn.Conv2d(2 * f, f * c, 3, padding=1, groups=f), nn.ReLU(),
            nn.Conv2d(f * c, f * c, 3, padding=1, groups=f), nn.ReLU(),
            nn.Conv2d(f * c, f * s, 1, groups=f),
        )
        half = patch // 2
        g = torch.arange(patch, dtype=torch.float32) - half
        u, v = torch.meshgrid(g, g, indexing="ij")  # u along the map's rows (x), v along columns
        self.register_buffer("u", u.reshape(-1))
        self.register_buffer("v", v.reshape(-1))
        win = torch.stack([torch.exp(-0.5 * (u * u + v * v) / (sc * sc)).reshape(-1)
                           for sc in cfg.fit_scales])
        self.register_buffer("window", win)  # (S, m m)
        n_cand = f + f * s
        self.choose = nn.Sequential(
            nn.Linear(3 * f + 3 * f * s, cfg.hidden1), nn.ReLU(), nn.Linear(cfg.hidden1, n_cand))
        nn.init.zeros_(self.choose[-1].weight)
        with torch.no_grad():  # start on the self normal (softmax weight ~0.99)
            self.choose[-1].bias.fill_(-3.0)
            self.choose[-1].bias[0] = 3.0 + math.log(float(n_cand))

    def fits(self, normals: torch.Tensor, maps: torch.Tensor) -> torch.Tensor:
        """(B, F, 3) normals, (B, F, m, m) maps -> (B, F S, 3) fitted unit normals."""
        b, f, s = normals.shape[0], self.f, self.scales
        occupied = (maps != 0).to(maps.dtype)  # empty bins are exactly 0 (height_map.cpp)
        x_in = torch.stack([maps, occupied], dim=2).reshape(b, 2 * f, self.patch, self.patch)
        w = F.softplus(self.weigher(x_in)).reshape(b, f, s, -1)
        w = w * self.window.unsqueeze(0).unsqueeze(0) * occupied.reshape(b, f, 1, -1) + 1e-6
        z = maps.reshape(b, f, 1, -1)
        u, v = self.u, self.v
        one = torch.ones_like(u)
        basis = torch.stack([u, v, one])  # (3, m m)
        a = torch.einsum("bfsk,ik,jk->bfsij", w, basis, basis)
        a = a + 1e-3 * torch.eye(3, dtype=a.dtype, device=a.device)
        rhs = torch.einsum("bfsk,ik->bfsi", w * z, basis)
        pq = solve3(a, rhs)  # (B, F, S, 3): slope along x, along y, offset
        n = normals.unsqueeze(2)
        ex = torch.zeros_like(n)
        ex[..., 0] = 1.0
        ey = torch.zeros_like(n)
        ey[..., 1] = 1.0
        x = ex - n[..., 0:1] * n  # e1 = (1, 0, 0) and e2 = (0, 1, 0) in the canonical frame
        x = torch.where((x * x).sum(-1, keepdim=True) < 1e-12, ey - n[..., 1:2] * n, x)
        x = F.normalize(x, dim=-1)
        y = ey - n[..., 1:2] * n - x[..., 1:2] * x
        y = torch.where((y * y).sum(-1, keepdim=True) < 1e-12, torch.cross(n.expand_as(x), x, dim=-1), y)
        y = F.normalize(y, dim=-1)
        fitted = n - pq[..., 0:1] * x - pq[..., 1:2] * y
        return F.normalize(fitted, dim=-1).reshape(b, f * s, 3)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        b, f = x.shape[0], self.f
        normals = x[:, : 3 * f].reshape(b, f, 3)
        maps = x[:, 3 * f:].reshape(b, f, self.patch, self.patch)
        mats = self.branches(maps).reshape(b, f, 3, 3)
        c = transformed(mats, normals)
        fitted = self.fits(normals, maps)
        cand = torch.cat([normals, fitted], dim=1)  # (B, F + F S, 3)
        alpha = torch.softmax(self.choose(torch.cat([c, fitted.reshape(b, -1)], dim=1)), dim=1)
        blend = (alpha.unsqueeze(-1) * cand).sum(dim=1)
        return F.normalize(blend + self.gather(c), dim=1)


class GroupedLinear(nn.Module):
    """`groups` independent linear layers, one per branch, as one batched matrix product:
    (G, B, i) -> (G, B, o). libtorch runs it as a batched GEMM (BLAS), where NH-Net's grouped
    convolutions of a few channels take oneDNN's slower paths."""

    def __init__(self, groups: int, inputs: int, outputs: int):
        super().__init__()
        bound = 1.0 / math.sqrt(inputs)  # nn.Linear's initialisation, per branch
        self.weight = nn.Parameter(torch.empty(groups, inputs, outputs).uniform_(-bound, bound))
        self.bias = nn.Parameter(torch.empty(groups, 1, outputs).uniform_(-bound, bound))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.baddbmm(self.bias, x, self.weight)


class NhNetMlp(nn.Module):
    """NH-Net with a small MLP per height map in place of each branch's CNN (issue 23: the
    network's speed on the CPU). Same input, output and gathering as NhNet: branch f maps its
    m x m map through `conv1` and `conv2` hidden units to a 3x3 matrix (tanh) applied to its
    normal. Every branch is a batched matrix product, ~0.05M multiply-adds a point at 64/32.

    `bfloat16_modules` (exported in the metadata): the layers the core may run in bfloat16
    (--precision bfloat16). They are nearly all the multiply-adds; the forward feeds them in
    their weights' dtype and takes their output back to the input's, so the 3x3 matrices, the
    gathering MLP and the residual stay float32: the gathering's first batch norm scales its
    inputs up ~100x, and tanh outputs rounded to bfloat16 moved the normals of a noisy sphere
    0.63 degree on average, where this split moves them 0.005 (decisions.md, "NH-Net in
    bfloat16")."""

    bfloat16_modules = ("layer1", "layer2")

    def __init__(self, cfg: TrainConfig, num_normals: int = NUM_NORMALS, patch: int = PATCH_SIZE):
        super().__init__()
        f, h1, h2 = num_normals, cfg.conv1, cfg.conv2
        self.f, self.patch, self.residual = f, patch, cfg.residual
        self.layer1 = GroupedLinear(f, patch * patch, h1)
        self.layer2 = GroupedLinear(f, h1, h2)
        self.layer3 = GroupedLinear(f, h2, 9)
        self.gather = NhNet(cfg, num_normals, patch).gather  # NhNet's gathering MLP, same init

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        b = x.shape[0]
        normals = x[:, : 3 * self.f].reshape(b, self.f, 3)
        maps = x[:, 3 * self.f:].reshape(b, self.f, self.patch * self.patch).transpose(0, 1)
        h = F.relu(self.layer2(F.relu(self.layer1(maps.to(self.layer1.weight.dtype)))))
        mats = torch.tanh(self.layer3(h.to(x.dtype))).transpose(0, 1).reshape(b, self.f, 3, 3)
        return head_output(self.gather(transformed(mats, normals)), normals, self.residual)


def build_model(cfg: TrainConfig) -> nn.Module:
    """The network `cfg.arch` names: "nhnet" (the paper's design, models up to v6), "fit" or
    "mlp"."""
    if cfg.arch == "nhnet":
        return NhNet(cfg)
    if cfg.arch == "fit":
        return NhNetFit(cfg)
    if cfg.arch == "mlp":
        return NhNetMlp(cfg)
    raise ValueError(f"unknown arch '{cfg.arch}' (nhnet, fit, mlp)")


def unoriented_angle_deg(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Per-row angle between unit vectors, sign ignored (the benchmark's metric)."""
    cos = (a * b).sum(dim=1).abs().clamp(max=1.0)
    return torch.rad2deg(torch.acos(cos))


def loss_fn(out: torch.Tensor, target: torch.Tensor, sin2_weight: float = 0.0,
            rms_weight: float = 0.0) -> torch.Tensor:
    """Eq. 8 without the L2 term (that is the optimiser's weight decay): ||N* - N_gt||^2, with the
    target oriented to the self normal's side (done in the dataset), plus two terms (issue 23).

    Eq. 8 is already close to the squared angle (4 sin^2(a/2) = a^2 (1 - a^2/12 + ...), 19 %
    below a^2 at 90 degrees), i.e. to RMS^2; the added terms change how the errors are weighed:

    - `sin2_weight` x mean sin^2(angle) = |N* x N_gt|^2: sign-free (unoriented), where Eq. 8
      punishes an output past 90 degrees from the MFPS side that is right up to its sign; its
      pull on a sample peaks at 45 degrees (gradient sin(2 angle)): the middle of the range;
    - `rms_weight` x sqrt(mean angle^2) (radians, unoriented, over the batch): the batch's RMS
      itself. Its pull on one sample is angle / (n RMS_batch): proportional to the sample's
      error and, unlike a mean of squares, not fading as the batch's errors shrink, so late in
      training the few large errors of a batch keep most of the gradient.

    The angle is atan2(|a x b|, |a . b|) with eps under the root: finite gradient at 0."""
    loss = ((out - target) ** 2).sum(dim=1).mean()
    if sin2_weight > 0.0 or rms_weight > 0.0:
        cross = torch.cross(out, target, dim=1)
        sin2 = (cross * cross).sum(dim=1)
        if sin2_weight > 0.0:
            loss = loss + sin2_weight * sin2.mean()
        if rms_weight > 0.0:
            ang = torch.atan2(torch.sqrt(sin2 + 1e-12), (out * target).sum(dim=1).abs())
            loss = loss + rms_weight * torch.sqrt((ang * ang).mean() + 1e-12)
    return loss
