"""Trains NH-Net (paper Sec. 5.2-5.3) on CPU from the generator's training split.

    nhnet-train --data-dir data/generated --out-dir runs/nhnet     # then: runs/nhnet/model.pt
    nhnet-train --out-dir runs/nhnet --resume                      # goes on from runs/nhnet/last.ckpt

Loss: Eq. 8 plus terms aimed at RMS (model.loss_fn); the model kept is the one with the lowest
validation RMS (`--select-by rms`, angle RMS over the validation split). Every epoch logs RMS,
mean, PGP5/PGP10 and the share over 30 degrees, overall, per CAD / organic model and per noise
level.

Resumable: `last.ckpt` (model, optimiser, weight average, schedule position, numpy and torch RNG
states, epoch and position in it, best validation, history) is written atomically (temp +
rename) every `--checkpoint-minutes` and after every epoch, and on SIGINT/SIGTERM. `--resume`
continues from it (a finished run goes on when the limit that stopped it, `--max-minutes`,
`--epochs` or `--patience`, is raised); with `--lr-schedule cosine-steps` or `constant` the continued run equals an
uninterrupted one exactly (tests/python/test_training_resume.py); the default time-based cosine
continues from the elapsed training minutes saved in the checkpoint."""
from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import math
import os
import signal
import sys
import time
from pathlib import Path

import numpy as np
import torch

from .config import TrainConfig
from .export import export
from .metrics import angle_stats, format_stats, grouped_stats
from .model import NhNet, build_model, loss_fn, unoriented_angle_deg

# Fields a resumed run may change (how long it goes on, how often it saves, threads); every other
# field comes from the checkpoint so the continued run trains the same thing.
RESUME_OVERRIDABLE = ("epochs", "max_minutes", "patience", "checkpoint_minutes", "threads")
CHECKPOINT_VERSION = 1


def _arg_parser(suppress: bool) -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="nhnet-train", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 argument_default=argparse.SUPPRESS if suppress else None)
    for f in dataclasses.fields(TrainConfig):
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        name = "--" + f.name.replace("_", "-")
        kw = {} if suppress else {"default": default}
        if isinstance(default, bool):
            ap.add_argument(name, type=lambda s: s.lower() in ("1", "true", "yes"), **kw)
        elif isinstance(default, list):
            ap.add_argument(name, nargs="+", type=type(default[0]), **kw)
        else:
            ap.add_argument(name, type=type(default), **kw)
    ap.add_argument("--resume", action="store_true",
                    help="continue from OUT_DIR/last.ckpt (its config; only "
                         + ", ".join(RESUME_OVERRIDABLE) + " may be changed)")
    return ap


def parse_args(argv=None) -> TrainConfig:
    a = vars(_arg_parser(False).parse_args(argv))
    a.pop("resume")
    return TrainConfig(**a)


def evaluate(model: NhNet, x: torch.Tensor, y: torch.Tensor, batch: int = 4096) -> np.ndarray:
    """Per-sample unoriented angle (degrees) of the model's output on (x, y)."""
    model.eval()
    errs = []
    with torch.no_grad():
        for i in range(0, len(x), batch):
            errs.append(unoriented_angle_deg(model(x[i:i + batch]), y[i:i + batch]))
    return torch.cat(errs).double().numpy() if errs else np.empty(0)


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


def sample_groups(data: dict, n: int) -> np.ndarray:
    """Report group of every sample: 'noise <level>%' (+ the density variant) parsed from its
    cloud's name (`<model>[_<variant>]_noise<level>`), 'all' when the data has no cloud names."""
    if "cloud" not in data or "names" not in data:
        return np.full(n, "all")
    labels = []
    for name in [str(s) for s in data["names"]]:
        head, _, level = name.rpartition("_noise")
        variant = next((v for v in ("gradient", "stripes") if head.endswith("_" + v)), "")
        labels.append(f"noise {level}%" + (f" {variant}" if variant else ""))
    return np.array(labels)[np.asarray(data["cloud"])]


def sample_kinds(data: dict, n: int) -> np.ndarray:
    """'CAD' or 'organic' (datagen's two lists of training models; the benchmark's categories do
    not apply to training shapes) of every sample's model, 'all' without cloud names."""
    if "cloud" not in data or "names" not in data:
        return np.full(n, "all")
    from .datagen import TRAIN_CAD

    models = [str(s).rpartition("_noise")[0] for s in data["names"]]
    models = [m.removesuffix("_gradient").removesuffix("_stripes") for m in models]
    return np.array(["CAD" if m in TRAIN_CAD else "organic" for m in models])[np.asarray(data["cloud"])]


def set_lr(cfg: TrainConfig, opt, step: int, steps_per_epoch: int, minutes: float) -> None:
    if cfg.lr_schedule == "cosine":
        # Time-based: the run ends at max_minutes with the step size near 0, which settles the
        # oscillation a constant rate shows between epochs.
        frac = min(minutes / cfg.max_minutes, 1.0)
    elif cfg.lr_schedule == "cosine-steps":
        frac = min(step / max(cfg.epochs * steps_per_epoch, 1), 1.0)
    else:
        return
    for g in opt.param_groups:
        g["lr"] = cfg.lr * 0.5 * (1 + math.cos(math.pi * frac))


def save_atomic(obj: dict, path: Path) -> None:
    """torch.save to a temporary file in the same folder, then rename over `path`: a kill at any
    moment leaves either the old or the new checkpoint, never a torn one."""
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        torch.save(obj, f)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def warm_start(model: torch.nn.Module, path: str) -> int:
    """Loads the tensors of `path` (an exported model.pt or a checkpoint) whose name and shape
    match the model's; returns how many. The rest keeps its initialisation."""
    if path.endswith(".ckpt"):
        src = torch.load(path, map_location="cpu")["model"]
    else:
        src = torch.jit.load(path, map_location="cpu").state_dict()
    own = model.state_dict()
    take = {k: v for k, v in src.items() if k in own and own[k].shape == v.shape}
    if not take:
        raise ValueError(f"{path}: no parameter matches the model (architecture or sizes differ)")
    model.load_state_dict(take, strict=False)
    return len(take)


class Run:
    """Everything a training run carries from step to step (what last.ckpt holds)."""

    def __init__(self, cfg: TrainConfig, data: dict):
        self.cfg = cfg
        torch.manual_seed(cfg.seed)
        self.rng = np.random.default_rng(cfg.seed)
        x = torch.from_numpy(np.ascontiguousarray(data["features"]))
        y = torch.from_numpy(np.ascontiguousarray(data["target"]))
        n = len(y)
        perm = self.rng.permutation(n)
        n_val = int(round(cfg.val_fraction * n))
        val, self.tr = perm[:n_val], perm[n_val:]
        self.x, self.y, self.xv, self.yv = x, y, x[val], y[val]
        self.groups = sample_groups(data, n)[val]
        self.kinds = sample_kinds(data, n)[val]
        self.base = angle_stats(unoriented_angle_deg(self.xv[:, 0:3], self.yv).numpy())
        self.model = build_model(cfg)
        self.warm = warm_start(self.model, cfg.init_from) if cfg.init_from else 0
        if cfg.optimizer == "sgd":
            self.opt = torch.optim.SGD(self.model.parameters(), lr=cfg.lr, momentum=0.9,
                                       weight_decay=cfg.weight_decay)
        else:
            self.opt = torch.optim.Adam(self.model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
        self.average = WeightAverage(self.model, cfg.ema_decay) if cfg.ema_decay > 0 else None
        self.steps_per_epoch = sum(1 for i in range(0, len(self.tr), cfg.batch) if len(self.tr) - i >= 2)
        self.s = {"epoch": 0, "pos": 0, "order": None, "total": 0.0, "seen": 0, "step": 0,
                  "minutes": 0.0, "best": float("inf"), "best_epoch": -1, "best_kind": "raw",
                  "history": [], "stopped": ""}

    def state_dict(self) -> dict:
        return {"version": CHECKPOINT_VERSION, "config": self.cfg.to_json(),
                "model": self.model.state_dict(), "optimizer": self.opt.state_dict(),
                "average": None if self.average is None else
                {"model": self.average.model.state_dict(), "steps": self.average.steps},
                "numpy_rng": self.rng.bit_generator.state, "torch_rng": torch.get_rng_state(),
                "run": copy.deepcopy(self.s)}

    def load_state_dict(self, ck: dict) -> None:
        if ck.get("version") != CHECKPOINT_VERSION:
            raise ValueError(f"checkpoint version {ck.get('version')}, this trainer reads {CHECKPOINT_VERSION}")
        self.model.load_state_dict(ck["model"])
        self.opt.load_state_dict(ck["optimizer"])
        if self.average is not None:
            self.average.model.load_state_dict(ck["average"]["model"])
            self.average.steps = ck["average"]["steps"]
        self.rng.bit_generator.state = ck["numpy_rng"]
        torch.set_rng_state(ck["torch_rng"])
        self.s = ck["run"]


def run_epoch(run: Run, t0: float, saver, should_stop) -> str:
    """Steps through the rest of the current epoch; returns "" at its end, else why it stopped."""
    cfg, s, model = run.cfg, run.s, run.model
    model.train()
    if s["order"] is None:
        s["order"] = torch.from_numpy(run.rng.permutation(run.tr))
    order = s["order"]
    last_save = time.time()
    while s["pos"] < len(order):
        idx = order[s["pos"]:s["pos"] + cfg.batch]
        s["pos"] += cfg.batch
        if len(idx) < 2:
            continue
        minutes = (time.time() - t0) / 60
        set_lr(cfg, run.opt, s["step"], run.steps_per_epoch, minutes)
        loss = loss_fn(model(run.x[idx]), run.y[idx], cfg.loss_sin2, cfg.loss_rms)
        run.opt.zero_grad()
        loss.backward()
        run.opt.step()
        if run.average is not None:
            run.average.update(model)
        s["step"] += 1
        s["total"] += float(loss) * len(idx)
        s["seen"] += len(idx)
        s["minutes"] = (time.time() - t0) / 60
        if should_stop(s["step"]):
            return "interrupted"
        if s["minutes"] > cfg.max_minutes:
            return "time cap"
        if time.time() - last_save > 60 * cfg.checkpoint_minutes:
            saver()
            last_save = time.time()
    return ""


def end_epoch(run: Run, log) -> bool:
    """Validates, records the epoch, keeps the best model (best.ckpt); True when it improved."""
    cfg, s = run.cfg, run.s
    key = cfg.select_by
    errs = evaluate(run.model, run.xv, run.yv)
    stats = angle_stats(errs)
    row = {"epoch": s["epoch"], "train_loss": s["total"] / max(s["seen"], 1), "val_deg": stats["mean"],
           "val_rms": stats["rms"], "val": stats, "minutes": s["minutes"],
           "val_groups": grouped_stats(errs, run.groups), "val_kinds": grouped_stats(errs, run.kinds)}
    kind, kept_stats, kept = "raw", stats, run.model
    shown = ""
    if run.average is not None:
        avg = angle_stats(evaluate(run.average.model, run.xv, run.yv))
        row["val_deg_average"], row["val_rms_average"], row["val_average"] = avg["mean"], avg["rms"], avg
        shown = f" (average RMS {avg['rms']:.3f} mean {avg['mean']:.3f})"
        if avg[key] < stats[key]:
            kind, kept_stats, kept = "average", avg, run.average.model
    s["history"].append(row)
    log(f"[train] epoch {s['epoch']} loss {row['train_loss']:.5f} val {format_stats(stats)}{shown} "
        f"(MFPS RMS {run.base['rms']:.3f} mean {run.base['mean']:.3f}) {s['minutes']:.1f} min")
    for g, gs in list(row["val_kinds"].items()) + list(row["val_groups"].items()):
        log(f"[train]   {g}: {format_stats(gs)}")
    improved = kept_stats[key] < s["best"]
    if improved:
        s["best"], s["best_epoch"], s["best_kind"] = kept_stats[key], s["epoch"], kind
        save_atomic({"model": kept.state_dict(), "config": run.cfg.to_json(),
                     "info": {"epoch": s["epoch"], "val_deg": kept_stats["mean"], "val_rms": kept_stats["rms"],
                              "weights": kind}}, Path(cfg.out_dir) / "best.ckpt")
    s["epoch"] += 1
    s["pos"], s["order"], s["total"], s["seen"] = 0, None, 0.0, 0
    return improved


def reopen(s: dict, cfg: TrainConfig) -> bool:
    """Whether a finished run goes on when resumed: the limit that stopped it (time cap, epochs,
    patience) was raised on the command line. The time-based cosine then restarts from the
    elapsed share of the new --max-minutes (a warm restart)."""
    if s["stopped"] == "time cap":
        return s["minutes"] < cfg.max_minutes
    if s["stopped"] == "epochs":
        return s["epoch"] < cfg.epochs
    if s["stopped"] == "patience":
        return s["epoch"] - 1 - s["best_epoch"] < cfg.patience
    return False


def resume_config(cfg: TrainConfig, argv) -> TrainConfig:
    """The checkpoint's config, with the RESUME_OVERRIDABLE fields given on the command line."""
    path = Path(cfg.out_dir) / "last.ckpt"
    if not path.exists():  # interrupted before the first checkpoint (e.g. building the data)
        return cfg
    ck = torch.load(path, map_location="cpu")
    saved = TrainConfig.from_dict(json.loads(ck["config"]))
    given = vars(_arg_parser(True).parse_args(argv))
    changed = {k: v for k, v in given.items() if k in RESUME_OVERRIDABLE}
    return dataclasses.replace(saved, **changed)


def train(cfg: TrainConfig, data: dict | None = None, log=print, resume: bool = False,
          stop_after_steps: int | None = None) -> dict:
    """Trains (or with `resume`, continues from out_dir/last.ckpt); `stop_after_steps` stops as an
    interruption would, after saving last.ckpt (tests)."""
    torch.set_num_threads(cfg.threads)
    # Denormal floats (weights decayed towards 0) are many times slower on the CPU: flush them
    # (epochs of the 2026-12-01 run slowed from 2.5 to 6.6 minutes without this).
    torch.set_flush_denormal(True)
    out_dir = Path(cfg.out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if data is None:
        from .dataset import build_dataset
        data = build_dataset(cfg, Path(cfg.cache) if cfg.cache else out_dir.parent / "dataset", log)
    run = Run(cfg, data)
    last = out_dir / "last.ckpt"
    if resume and not last.exists():
        log(f"[train] --resume: no {last} yet, starting from the beginning")
        resume = False
    if resume:
        run.load_state_dict(torch.load(last, map_location="cpu"))
        log(f"[train] resumed {last}: epoch {run.s['epoch']}, step {run.s['step']}, "
            f"{run.s['minutes']:.1f} min, best {cfg.select_by} {run.s['best']:.3f}")
        if reopen(run.s, cfg):
            log(f"[train] the run had stopped ({run.s['stopped']}); the raised limit lets it go on")
            run.s["stopped"] = ""
    params = sum(p.numel() for p in run.model.parameters())
    if cfg.init_from:
        log(f"[train] warm start: {run.warm} tensors from {cfg.init_from}")
        if not resume:  # the figure training has to beat (the warm start's own error)
            run.s["start_val"] = angle_stats(evaluate(run.model, run.xv, run.yv))
            log(f"[train] before training: val {format_stats(run.s['start_val'])}")
    log(f"[train] {len(run.tr)} train / {len(run.yv)} val samples, {params} parameters; "
        f"MFPS input on val: {format_stats(run.base)}")
    interrupted = {"flag": False}

    def on_signal(signum, frame):  # finish the step, save, stop
        interrupted["flag"] = True

    handlers = {}
    if __import__("threading").current_thread() is __import__("threading").main_thread():
        handlers = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        t0 = time.time() - 60 * run.s["minutes"]
        should_stop = lambda step: interrupted["flag"] or (stop_after_steps is not None
                                                           and step >= stop_after_steps)
        while not run.s["stopped"]:
            why = run_epoch(run, t0, lambda: save_atomic(run.state_dict(), last), should_stop)
            if why == "interrupted":
                save_atomic(run.state_dict(), last)
                log(f"[train] interrupted at epoch {run.s['epoch']} step {run.s['step']}; saved {last}")
                return {"stopped": "interrupted", "epoch": run.s["epoch"], "step": run.s["step"]}
            end_epoch(run, log)
            s = run.s
            if why == "time cap" or s["minutes"] > cfg.max_minutes:
                s["stopped"] = "time cap"
            elif s["epoch"] - 1 - s["best_epoch"] >= cfg.patience:
                s["stopped"] = "patience"
            elif s["epoch"] >= cfg.epochs:
                s["stopped"] = "epochs"
            save_atomic(run.state_dict(), last)
    finally:
        for sig, h in handlers.items():
            signal.signal(sig, h)
    return finish(run, data, params, log)


def finish(run: Run, data: dict, params: int, log) -> dict:
    """Exports the best model (model.pt) and writes history.json."""
    cfg, s, out_dir = run.cfg, run.s, Path(run.cfg.out_dir)
    ck = torch.load(out_dir / "best.ckpt", map_location="cpu")
    run.model.load_state_dict(ck["model"])
    best_row = s["history"][s["best_epoch"]]
    kept = best_row["val_average"] if s["best_kind"] == "average" else best_row["val"]
    info = {"best_epoch": s["best_epoch"], "weights": s["best_kind"], "select_by": cfg.select_by,
            "val_deg": kept["mean"], "val_rms": kept["rms"], "val": kept, "val_mfps": run.base,
            "val_mfps_deg": run.base["mean"], "train_samples": int(len(run.tr)),
            "val_samples": int(len(run.yv)), "parameters": params, "train_minutes": s["minutes"],
            "steps": s["step"], "epochs_run": s["epoch"], "stopped": s["stopped"],
            "val_before_training": s.get("start_val"),
            "clouds": [str(c) for c in data.get("names", [])]}
    export(run.model, cfg, str(out_dir / "model.pt"), info)
    (out_dir / "history.json").write_text(json.dumps({"info": info, "history": s["history"]}, indent=1))
    log(f"[train] best val {format_stats(kept)} (MFPS {format_stats(run.base)}) at epoch "
        f"{s['best_epoch']} ({s['best_kind']} weights); exported {out_dir / 'model.pt'}")
    return info


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    cfg = parse_args(argv)
    resume = "--resume" in argv
    if resume:
        cfg = resume_config(cfg, argv)
    info = train(cfg, resume=resume)
    return 3 if info.get("stopped") == "interrupted" else 0


if __name__ == "__main__":
    raise SystemExit(main())
