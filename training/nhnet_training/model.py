"""NH-Net (paper Sec. 5.2): 9 HMP branches each producing a 3x3 matrix applied to its (rotated)
normal, then a gathering MLP; output L2-normalised, in the canonical frame.

Input: the core's descriptor, (B, D) float32 with D = 3 F + F m^2: F rotated normals then F
m x m height maps (core/include/nhnet/learned/descriptors.hpp). The 9 branches have separate weights,
run as grouped convolutions (one call for all branches)."""
from __future__ import annotations

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
        c = torch.matmul(mats, normals.unsqueeze(-1)).reshape(b, 3 * self.f)
        out = self.gather(c)
        if self.residual:
            out = out + normals[:, 0, :]
        return F.normalize(out, dim=1)


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
