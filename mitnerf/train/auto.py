"""Let the data choose: the smallest model that reaches a target, and whether view
dependence earns its place, each from short probe runs that start from the recipes.

:func:`auto_size` tries candidates (field family and size from ``LADDER``, each the
family's recipe with that size) in order of parameter count; every probe trains the same
number of steps with the same seed (a deterministic search) and is judged by validation
PSNR. The first to reach ``target_psnr`` is the size; then fewer samples are tried, view
dependence is kept only if it raises validation PSNR by ``vd_gain`` dB, and so is each
regulariser of ``regularisers`` (the distortion loss against floaters, the opacity entropy
against haze) by ``reg_gain`` dB. Every trial is kept as evidence, and every decision gives
its reason.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

from ..data.dataset import Dataset
from ..fields import make_field
from .fit import fit
from .recipes import Recipe, recipe_for

LADDER = {
    2: [("grid", dict(resolution=r, initial_resolution=r, upsample_at=())) for r in (9, 17, 33, 65, 129, 257, 513)]
    + [("vanilla", dict(width=w, depth=3 if w < 64 else 4, pos_L=L, dir_L=2, view_dependent=False))
       for w, L in ((16, 4), (32, 6), (64, 8))]
    + [("hashgrid", dict(n_levels=8, log2_hashmap_size=T, hidden=16, geo_features=7)) for T in (10, 12, 14)],
    3: [("grid", dict(resolution=r, initial_resolution=r, upsample_at=())) for r in (17, 33, 65, 129)]
    + [("vanilla", dict(width=w, depth=4, pos_L=L, dir_L=2, view_dependent=False)) for w, L in ((32, 6), (64, 8))]
    + [("hashgrid", dict(n_levels=12, log2_hashmap_size=T)) for T in (12, 14, 16)],
}
"""Candidate (family, settings) per dimension, before sorting by parameter count."""


@dataclass
class AutoConfig:
    """The search."""

    target_psnr: float = 30.0
    """Validation PSNR a model must reach."""
    steps: int = 400
    """Training steps per probe (the same for all: a deterministic search)."""
    time_budget: float = 300.0
    """Seconds for the whole search; past it, the best candidate so far is returned."""
    families: tuple = ("grid", "vanilla", "hashgrid")
    """Field families to consider."""
    samples: int = 64
    """Samples per ray of the size probes."""
    vd_gain: float = 0.2
    """Minimum validation-PSNR gain (dB) for view dependence to be kept."""
    regularisers: tuple = (("distortion_weight", 1e-3), ("opacity_weight", 1e-3))
    """(training setting, weight) pairs tried one at a time on the chosen model."""
    reg_gain: float = 0.2
    """Minimum validation-PSNR gain (dB) for a regulariser to be kept."""
    seed: int = 0
    """Seed of every probe."""


@dataclass
class Trial:
    recipe: Recipe
    params: int
    val_psnr: float
    train_time: float
    note: str = ""


@dataclass
class AutoResult:
    recipe: Recipe
    trials: list = field(default_factory=list)
    reached: bool = False
    reasons: list = field(default_factory=list)

    @property
    def model(self):
        return self.recipe.model

    def table(self) -> list[dict]:
        return [dict(family=t.recipe.model.field, settings=", ".join(f"{k}={v}" for k, v in
                                                                     t.recipe.model.field_args.items()),
                     samples=t.recipe.model.render.n_coarse, params=t.params, val_psnr=round(t.val_psnr, 2),
                     train_s=round(t.train_time, 1), note=t.note) for t in self.trials]


def probe_recipe(family: str, args: dict, dim: int, cfg: AutoConfig, background) -> Recipe:
    """The family's recipe at the given size, trained ``cfg.steps`` steps and validated once at the end."""
    r = recipe_for(family, dim).override(**args, iters=cfg.steps, seed=cfg.seed, val_every=0, val_views=100,
                                         n_coarse=cfg.samples, background=background, progress=False)
    r.train.time_budget, r.model.render.occupancy.enabled = None, False
    return r


def _trial(dataset: Dataset, recipe: Recipe, note: str) -> Trial:
    run = fit(dataset, recipe.copy(), "drjit", progress=False)
    val = run.state.history["val_psnr"]
    return Trial(recipe, run.backend.n_params(), val[-1] if val else -math.inf, run.state.train_time, note)


def auto_size(dataset: Dataset, cfg: AutoConfig | None = None) -> AutoResult:
    """The smallest candidate that reaches ``cfg.target_psnr``; see the module docstring."""
    cfg = cfg or AutoConfig()
    t0 = time.perf_counter()
    bg = dataset.background
    size = lambda fam, args: sum(v.size for v in make_field(fam, **{**args, "dim": dataset.dim}).init_numpy(0).values())
    cands = sorted((c for c in LADDER[dataset.dim] if c[0] in cfg.families), key=lambda c: size(*c))
    trials: list[Trial] = []
    best = None
    for family, args in cands:
        if time.perf_counter() - t0 > cfg.time_budget:
            break
        t = _trial(dataset, probe_recipe(family, args, dataset.dim, cfg, bg), "size")
        trials.append(t)
        if best is None or t.val_psnr > best.val_psnr or t.val_psnr >= cfg.target_psnr:
            best = t
        if t.val_psnr >= cfg.target_psnr:
            break
    reached = best.val_psnr >= cfg.target_psnr
    fam = best.recipe.model.field
    reasons = [f"{fam} with {best.params} parameters is the smallest candidate to reach {cfg.target_psnr:.1f} dB "
               f"({best.val_psnr:.2f} dB)" if reached else
               f"no candidate reached {cfg.target_psnr:.1f} dB within the budget; best: {fam} ({best.val_psnr:.2f} dB)"]
    for samples in (32, 16):                       # fewer samples?
        if samples >= best.recipe.model.render.n_coarse or time.perf_counter() - t0 > cfg.time_budget:
            continue
        t = _trial(dataset, best.recipe.override(n_coarse=samples), "samples")
        trials.append(t)
        if t.val_psnr >= min(cfg.target_psnr, best.val_psnr - 0.1):
            reasons.append(f"{samples} samples per ray are enough ({t.val_psnr:.2f} dB)")
            best = t
        else:
            reasons.append(f"{samples} samples per ray lose quality ({t.val_psnr:.2f} dB): keep "
                           f"{best.recipe.model.render.n_coarse}")
            break
    if time.perf_counter() - t0 <= cfg.time_budget:    # view dependence has to earn its place
        t = _trial(dataset, best.recipe.override(view_dependent=True), "view dependence")
        trials.append(t)
        gain = t.val_psnr - best.val_psnr
        if gain >= cfg.vd_gain:
            reasons.append(f"view dependence kept: +{gain:.2f} dB validation PSNR")
            best = t
        else:
            reasons.append(f"view dependence dropped: it changed validation PSNR by {gain:+.2f} dB "
                           f"(< {cfg.vd_gain} dB)")
    for key, weight in cfg.regularisers:              # so does each regulariser
        if time.perf_counter() - t0 > cfg.time_budget:
            reasons.append(f"{key} not tried: the search budget is spent")
            continue
        t = _trial(dataset, best.recipe.override(**{key: weight}), key)
        trials.append(t)
        gain = t.val_psnr - best.val_psnr
        verb = "kept" if gain >= cfg.reg_gain else "dropped"
        reasons.append(f"{key} = {weight:g} {verb}: {gain:+.2f} dB validation PSNR (threshold {cfg.reg_gain} dB)")
        if gain >= cfg.reg_gain:
            best = t
    return AutoResult(best.recipe, trials, reached, reasons)


def choose_recipe(dataset: Dataset, base: Recipe, backend: str = "drjit",
                  cfg: AutoConfig | None = None) -> tuple[Recipe, list[str]]:
    """``fit --auto``: the smallest model that reaches the target, trained with its family's
    full recipe (budget and schedule); returns it and the reasons."""
    result = auto_size(dataset, cfg)
    chosen = recipe_for(result.recipe.model.field, dataset.dim)
    chosen.model.field_args.update(result.recipe.model.field_args)
    chosen.model.render.n_coarse = result.recipe.model.render.n_coarse
    for key, _ in (cfg or AutoConfig()).regularisers:
        setattr(chosen.train, key, getattr(result.recipe.train, key))
    chosen.name = f"auto:{chosen.name}"
    lines = [f"{t['family']} ({t['settings']}), {t['samples']} samples: {t['params']} parameters, "
             f"validation {t['val_psnr']} dB [{t['note']}]" for t in result.table()]
    return chosen.validate(), lines + result.reasons
