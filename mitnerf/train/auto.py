"""Model no more than a scene needs: find the smallest model that reaches a target PSNR.

Candidates (field family, resolution or width, positional-encoding L, samples) are
tried in order of parameter count; each trains for the same number of steps (so the
search is deterministic for a seed) and is judged by validation PSNR. The first to
reach ``target_psnr`` is the size; then fewer samples are tried on it, and view
dependence has to earn its place (kept only if it raises validation PSNR by at least
``vd_gain`` dB). The search stops when its time budget is spent and reports the best
candidate so far. Every trial is kept as evidence.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

from ..data.dataset import Dataset
from ..render.pipeline import RenderConfig
from .config import ModelConfig, TrainConfig
from .trainer import fit


def ladder(dim: int) -> list[tuple[str, dict, int]]:
    """Candidate (family, field arguments, samples), before sorting by size."""
    out = []
    for res in ((9, 17, 33, 65, 129, 257, 513) if dim == 2 else (17, 33, 65, 129)):
        out.append(("grid", dict(resolution=res, initial_resolution=res, tv_weight=1e-4), 64))
    for width, L in ((16, 4), (32, 6), (64, 8)):
        out.append(("vanilla", dict(width=width, depth=3 if width < 64 else 4, pos_L=L, dir_L=2,
                                    view_dependent=False), 64))
    for T in (10, 12, 14):
        out.append(("hashgrid", dict(n_levels=8, log2_hashmap_size=T, hidden=16, geo_features=7), 64))
    return out


LR = {"grid": (0.05, 0.005), "vanilla": (5e-3, 5e-4), "hashgrid": (0.02, 0.002)}


@dataclass
class AutoConfig:
    """The search."""

    target_psnr: float = 30.0
    """Validation PSNR a model must reach."""
    steps: int = 400
    """Training steps per candidate (the same for all: a deterministic search)."""
    time_budget: float = 300.0
    """Seconds for the whole search; past it, the best candidate so far is returned."""
    families: tuple = ("grid", "vanilla", "hashgrid")
    """Field families to consider."""
    vd_gain: float = 0.2
    """Minimum validation-PSNR gain (dB) for view dependence to be kept."""
    seed: int = 0
    """Seed of every candidate's training."""
    batch_rays: int = 1024
    """Rays per step."""


@dataclass
class Trial:
    family: str
    field_args: dict
    samples: int
    params: int
    val_psnr: float
    train_time: float
    note: str = ""


@dataclass
class AutoResult:
    model: ModelConfig
    train: TrainConfig
    trials: list = field(default_factory=list)
    reached: bool = False
    reasons: list = field(default_factory=list)

    def table(self) -> str:
        from ..experiments.common import markdown_table

        rows = [dict(family=t.family, args=", ".join(f"{k}={v}" for k, v in t.field_args.items()
                                                     if k not in ("initial_resolution", "tv_weight")),
                     samples=t.samples, params=t.params, val_psnr=t.val_psnr, train_s=t.train_time, note=t.note)
                for t in self.trials]
        return markdown_table(rows, fmt={"val_psnr": ".2f", "train_s": ".1f"})


def n_params(family: str, args: dict, dim: int) -> int:
    from ..fields import make_field

    f = make_field(family, **{**args, "dim": dim})
    return int(sum(v.size for v in f.to_numpy(f.init_params(0)).values()))


def _trial(dataset: Dataset, family: str, args: dict, samples: int, cfg: AutoConfig, note: str = "") -> Trial:
    lr, lr_final = LR[family]
    mc = ModelConfig(family, dict(args), RenderConfig(n_coarse=samples, background=dataset.background))
    tc = TrainConfig(iters=cfg.steps, lr=lr, lr_final=lr_final, batch_rays=cfg.batch_rays, seed=cfg.seed,
                     val_every=0, val_views=100, progress=False)
    run = fit(dataset, mc, tc, "drjit")
    return Trial(family, dict(args), samples, n_params(family, args, dataset.dim), run.history["val_psnr"][-1],
                 run.train_time, note)


def auto_size(dataset: Dataset, cfg: AutoConfig | None = None) -> AutoResult:
    """Search as described in the module docstring; returns the chosen configs and the evidence."""
    cfg = cfg or AutoConfig()
    t0 = time.perf_counter()
    cands = [c for c in ladder(dataset.dim) if c[0] in cfg.families]
    cands.sort(key=lambda c: n_params(c[0], c[1], dataset.dim))
    trials: list[Trial] = []
    best = None
    for family, args, samples in cands:
        if time.perf_counter() - t0 > cfg.time_budget:
            break
        t = _trial(dataset, family, args, samples, cfg, "size")
        trials.append(t)
        if best is None or t.val_psnr > best.val_psnr:
            best = t
        if t.val_psnr >= cfg.target_psnr:
            best = t
            break
    reached = best.val_psnr >= cfg.target_psnr
    reasons = [f"{best.family} with {best.params} parameters is the smallest candidate to reach "
               f"{cfg.target_psnr:.1f} dB ({best.val_psnr:.2f} dB)" if reached else
               f"no candidate reached {cfg.target_psnr:.1f} dB within the budget; best: {best.family} "
               f"({best.val_psnr:.2f} dB)"]
    # fewer samples?
    for samples in (32, 16):
        if samples >= best.samples or time.perf_counter() - t0 > cfg.time_budget:
            continue
        t = _trial(dataset, best.family, best.field_args, samples, cfg, "samples")
        trials.append(t)
        if t.val_psnr >= min(cfg.target_psnr, best.val_psnr - 0.1):
            reasons.append(f"{samples} samples per ray are enough ({t.val_psnr:.2f} dB)")
            best = dataclasses.replace(t, note="chosen")
        else:
            reasons.append(f"{samples} samples per ray lose quality ({t.val_psnr:.2f} dB): keep {best.samples}")
            break
    # view dependence has to earn its place
    vd_args = {**best.field_args, "view_dependent": True}
    if best.family == "vanilla":
        vd_args["dir_L"] = 2
    if time.perf_counter() - t0 <= cfg.time_budget:
        t = _trial(dataset, best.family, vd_args, best.samples, cfg, "view dependence")
        trials.append(t)
        gain = t.val_psnr - best.val_psnr
        if gain >= cfg.vd_gain:
            reasons.append(f"view dependence kept: +{gain:.2f} dB validation PSNR")
            best = t
        else:
            reasons.append(f"view dependence dropped: it changed validation PSNR by {gain:+.2f} dB "
                           f"(< {cfg.vd_gain} dB)")
    lr, lr_final = LR[best.family]
    model = ModelConfig(best.family, dict(best.field_args), RenderConfig(n_coarse=best.samples,
                                                                          background=dataset.background))
    train = TrainConfig(iters=cfg.steps, lr=lr, lr_final=lr_final, batch_rays=cfg.batch_rays, seed=cfg.seed)
    return AutoResult(model, train, trials, reached, reasons)
