"""Training configuration: one dataclass, saved with every checkpoint and exported model."""
from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from typing import List

# Must match the core (core/include/nhnet/learned/descriptors.hpp); the C++ loader checks these.
DESCRIPTOR_VERSION = 2
HEIGHT_NORMALISATION = "cell"
SIGMA_S = [1.0, 2.0]
SIGMA_R = [0.1, 0.2, 0.35, 0.5]
PATCH_SIZE = 7
NEIGHBORHOOD_FACTOR = 1.5
NUM_NORMALS = 1 + len(SIGMA_S) * len(SIGMA_R)
MODEL_FORMAT = 2


def descriptor_size(patch: int = PATCH_SIZE, normals: int = NUM_NORMALS) -> int:
    return 3 * normals + normals * patch * patch


@dataclass
class TrainConfig:
    # data
    data_dir: str = "data/generated"          # nhnet-datagen output (its train/ split is used)
    noise_levels: List[float] = field(default_factory=lambda: [0.05, 0.1, 0.2, 0.3, 0.6])
    variants: List[str] = field(default_factory=lambda: ["uniform"])
    samples_per_cloud: int = 4000              # random points kept per training cloud
    val_fraction: float = 0.15                 # per point, as the authors (85/15)
    max_clouds: int = 0                        # 0 = all matching clouds
    levels_per_model: int = 2                  # noise levels kept per model (0 = all of them)
    cache: str = ""                            # .npz of the built dataset ("" = none)
    # network (authors: 64/128 channels, 1.34M parameters per cluster network)
    conv1: int = 16
    conv2: int = 32
    hidden1: int = 64
    hidden2: int = 32
    dropout: float = 0.3
    residual: bool = True                      # output = normalise(self normal + correction)
    arch: str = "nhnet"                        # "nhnet": the paper's design (up to v6); "fit":
                                               # + learned weighted plane fits (model.NhNetFit);
                                               # "mlp": an MLP per map, conv1/conv2 its widths
    init_from: str = ""                        # warm start: model.pt (TorchScript) or a .ckpt whose
                                               # parameters of the same name and shape are loaded
                                               # (v6 -> the "fit" network's branches and gather)
    fit_channels: int = 8                      # "fit": channels of the per-map weight CNN
    fit_scales: List[float] = field(default_factory=lambda: [1.5, 3.5])  # "fit": window sigmas
                                               # (cells) of the plane fits, one fit per scale
    # optimisation (authors: SGD lr 1e-4 momentum 0.9 wd 0.02, batch 512, patience 30)
    optimizer: str = "adam"
    lr: float = 1e-3
    lr_schedule: str = "cosine"               # "cosine": decays to 0 over max_minutes (wall clock);
                                               # "cosine-steps": to 0 over `epochs` epochs by step
                                               # count (exactly resumable); "constant"
    weight_decay: float = 1e-5
    batch: int = 512
    epochs: int = 20
    patience: int = 5
    max_minutes: float = 35.0                  # wall-clock cap of the training loop
    threads: int = 2
    ema_decay: float = 0.0                     # weight average per step (0 = off); the average is
                                               # validated beside the raw weights every epoch and
                                               # kept when it is better
    seed: int = 1
    # loss (model.loss_fn): Eq. 8 + these weights x the RMS-aimed terms (0, 0 = Eq. 8 alone, v6)
    loss_sin2: float = 1.0                     # x mean sin^2(angle)
    loss_rms: float = 0.25                     # x batch RMS of the angle (radians)
    select_by: str = "rms"                     # model selection on validation "rms" or "mean"
    checkpoint_minutes: float = 10.0           # resumable checkpoint (last.ckpt) at least this
                                               # often, and after every epoch
    # output
    out_dir: str = "runs/nhnet"

    def to_json(self) -> str:
        return json.dumps(dataclasses.asdict(self), sort_keys=True)

    @staticmethod
    def from_dict(d: dict) -> "TrainConfig":
        names = {f.name for f in dataclasses.fields(TrainConfig)}
        return TrainConfig(**{k: v for k, v in d.items() if k in names})


def metadata(cfg: TrainConfig) -> dict:
    """What the C++ loader checks (descriptor definition) plus provenance."""
    return {
        "format": "nhnet-model",
        "descriptor_version": DESCRIPTOR_VERSION,
        "descriptor_size": descriptor_size(),
        "num_normals": NUM_NORMALS,
        "sigma_s": SIGMA_S,
        "sigma_r": SIGMA_R,
        "patch_size": PATCH_SIZE,
        "neighborhood_factor": NEIGHBORHOOD_FACTOR,
        "height_normalisation": HEIGHT_NORMALISATION,
        "output": "unit normal in the canonical frame",
        # 2 since the "fit" architecture (models up to v6 have no key: format 1, arch "nhnet");
        # the C++ loader reads neither, both formats take the same descriptor and give the same
        # output, so every version loads.
        "model_format": MODEL_FORMAT,
        "architecture": cfg.arch,
        "config": dataclasses.asdict(cfg),
    }
