"""Trains NH-Net (paper Sec. 5.2-5.3) on CPU from the generator's training split.

    nhnet-train --data-dir data/generated --out-dir runs/nhnet     # then: runs/nhnet/model.pt

Every checkpoint holds the TrainConfig (JSON); the best-validation model (mean unoriented angle)
is exported to TorchScript with metadata (export.py)."""
from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import math
import time
from pathlib import Path

import numpy as np
import torch

from .config import TrainConfig
from .export import export
from .model import NhNet, loss_fn, unoriented_angle_deg


def parse_args(argv=None) -> TrainConfig:
    ap = argparse.ArgumentParser(prog="nhnet-train", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    for f in dataclasses.fields(TrainConfig):
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        name = "--" + f.name.replace("_", "-")
        if isinstance(default, bool):
            ap.add_argument(name, type=lambda s: s.lower() in ("1", "true", "yes"), default=default)
        elif isinstance(default, list):
            ap.add_argument(name, nargs="+", type=type(default[0]), default=default)
        else:
            ap.add_argument(name, type=type(default), default=default)
    return TrainConfig(**vars(ap.parse_args(argv)))


def evaluate(model: NhNet, x: torch.Tensor, y: torch.Tensor, batch: int = 4096) -> float:
    model.eval()
    errs = []
    with torch.no_grad():
        for i in range(0, len(x), batch):
            errs.append(unoriented_angle_deg(model(x[i:i + batch]), y[i:i + batch]))
    return float(torch.cat(errs).mean()) if errs else float("nan")


class WeightAverage:
    """Exponential moving average of a model's parameters and buffers (BatchNorm statistics too),
    updated after every optimiser step; the decay ramps up over the first steps
    (min(decay, (1 + t) / (10 + t))) so the average does not start from the random weights."""

    def __init__(self, model: NhNet, decay: float):
        self.decay, self.steps = decay, 0
        self.model = copy.deepcopy(model)

    @torch.no_grad()
    def update(self, model: NhNet) -> None:
        self.steps += 1
        d = min(self.decay, (1 + self.steps) / (10 + self.steps))
        for a, b in zip(self.model.state_dict().values(), model.state_dict().values()):
            if a.dtype.is_floating_point:
                a.mul_(d).add_(b, alpha=1 - d)
            else:
                a.copy_(b)


def train(cfg: TrainConfig, data: dict | None = None, log=print) -> dict:
    torch.set_num_threads(cfg.threads)
    # Denormal floats (weights decayed towards 0) are many times slower on the CPU: flush them
    # (epochs of the 2026-12-01 run slowed from 2.5 to 6.6 minutes without this).
    torch.set_flush_denormal(True)
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    out_dir = Path(cfg.out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if data is None:
        from .dataset import build_dataset
        data = build_dataset(cfg, Path(cfg.cache) if cfg.cache else out_dir.parent / "dataset", log)
    x = torch.from_numpy(np.ascontiguousarray(data["features"]))
    y = torch.from_numpy(np.ascontiguousarray(data["target"]))
    n = len(y)
    perm = rng.permutation(n)
    n_val = int(round(cfg.val_fraction * n))
    val, tr = perm[:n_val], perm[n_val:]
    xv, yv = x[val], y[val]
    base_val = float(unoriented_angle_deg(xv[:, 0:3], yv).mean())  # the MFPS normal's error
    model = NhNet(cfg)
    params = sum(p.numel() for p in model.parameters())
    if cfg.optimizer == "sgd":
        opt = torch.optim.SGD(model.parameters(), lr=cfg.lr, momentum=0.9, weight_decay=cfg.weight_decay)
    else:
        opt = torch.optim.Adam(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    log(f"[train] {len(tr)} train / {n_val} val samples, {params} parameters; "
        f"MFPS input on val: {base_val:.3f} deg")
    average = WeightAverage(model, cfg.ema_decay) if cfg.ema_decay > 0 else None
    best, best_epoch, best_kind, history = float("inf"), -1, "raw", []
    t0 = time.time()
    ck_path = out_dir / "best.ckpt"
    stopped = "epochs"
    for epoch in range(cfg.epochs):
        model.train()
        order = torch.from_numpy(rng.permutation(tr))
        total, seen = 0.0, 0
        for i in range(0, len(order), cfg.batch):
            idx = order[i:i + cfg.batch]
            if len(idx) < 2:
                continue
            if cfg.lr_schedule == "cosine":
                # Time-based cosine decay: the run ends at max_minutes with the step size near 0,
                # which settles the oscillation a constant rate shows between epochs.
                frac = min((time.time() - t0) / 60 / cfg.max_minutes, 1.0)
                for g in opt.param_groups:
                    g["lr"] = cfg.lr * 0.5 * (1 + math.cos(math.pi * frac))
            loss = loss_fn(model(x[idx]), y[idx])
            opt.zero_grad()
            loss.backward()
            opt.step()
            if average is not None:
                average.update(model)
            total += float(loss) * len(idx)
            seen += len(idx)
            if (time.time() - t0) / 60 > cfg.max_minutes:
                break
        v = evaluate(model, xv, yv)
        row = {"epoch": epoch, "train_loss": total / max(seen, 1), "val_deg": v,
               "minutes": (time.time() - t0) / 60}
        kind, v_kept, kept, shown = "raw", v, model, ""
        if average is not None:
            v_avg = row["val_deg_average"] = evaluate(average.model, xv, yv)
            shown = f" (average {v_avg:.3f})"
            if v_avg < v:
                kind, v_kept, kept = "average", v_avg, average.model
        history.append(row)
        log(f"[train] epoch {epoch} loss {total / max(seen, 1):.5f} val {v:.3f} deg{shown} "
            f"(MFPS {base_val:.3f}) {(time.time() - t0) / 60:.1f} min")
        if v_kept < best:
            best, best_epoch, best_kind = v_kept, epoch, kind
            torch.save({"model": kept.state_dict(), "config": cfg.to_json(),
                        "info": {"epoch": epoch, "val_deg": v_kept, "weights": kind}}, ck_path)
        if epoch - best_epoch >= cfg.patience:
            stopped = "patience"
            break
        if (time.time() - t0) / 60 > cfg.max_minutes:
            stopped = "time cap"
            break
    ck = torch.load(ck_path, map_location="cpu")
    model.load_state_dict(ck["model"])
    info = {"best_epoch": best_epoch, "weights": best_kind, "val_deg": best, "val_mfps_deg": base_val,
            "train_samples": int(len(tr)), "val_samples": int(n_val), "parameters": params,
            "train_minutes": (time.time() - t0) / 60, "stopped": stopped,
            "clouds": [str(s) for s in data.get("names", [])]}
    export(model, cfg, str(out_dir / "model.pt"), info)
    (out_dir / "history.json").write_text(json.dumps({"info": info, "history": history}, indent=1))
    log(f"[train] best val {best:.3f} deg (MFPS {base_val:.3f}) at epoch {best_epoch} "
        f"({best_kind} weights); "
        f"exported {out_dir / 'model.pt'}")
    return info


def main(argv=None) -> int:
    train(parse_args(argv))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
