"""Let the data choose the smallest model that reaches a target, from short probe runs: :func:`auto_size`
probes ``LADDER``'s candidates by parameter count (same steps and seed, judged by validation PSNR); the first
to reach ``target_psnr`` is the size. Then fewer samples are tried, and view dependence and each regulariser
are kept only if they gain ``vd_gain`` / ``reg_gain`` dB. Every trial and every decision's reason is kept."""

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


def auto_size(dataset: Dataset, cfg: AutoConfig | None = None) -> AutoResult:
    """The smallest candidate that reaches ``cfg.target_psnr``; see the module docstring."""
    cfg = cfg or AutoConfig()
    t0 = time.perf_counter()
    spent = lambda: time.perf_counter() - t0 > cfg.time_budget
    size = lambda fam, args: sum(v.size for v in make_field(fam, **{**args, "dim": dataset.dim}).init_numpy(0).values())
    cands = sorted((c for c in LADDER[dataset.dim] if c[0] in cfg.families), key=lambda c: size(*c))
    trials: list[Trial] = []

    def trial(recipe: Recipe, note: str) -> Trial:
        run = fit(dataset, recipe.copy(), "drjit", progress=False)
        val = run.state.history["val_psnr"]
        trials.append(Trial(recipe, run.backend.n_params(), val[-1] if val else -math.inf, run.state.train_time, note))
        return trials[-1]

    best = None
    for family, args in cands:
        if spent() and best is not None:        # at least one candidate, whatever the budget
            break
        r = recipe_for(family, dataset.dim).override(**{"view_dependent": False, **args}, iters=cfg.steps,
                                                     seed=cfg.seed, val_every=0, val_views=100, n_coarse=cfg.samples,
                                                     background=dataset.background, progress=False,
                                                     **{key: 0.0 for key, _ in cfg.regularisers})
        r.train.time_budget, r.model.render.occupancy.enabled = None, False   # probes: cfg.steps steps, one validation
        t = trial(r, "size")
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
        if samples >= best.recipe.model.render.n_coarse or spent():
            continue
        t = trial(best.recipe.override(n_coarse=samples), "samples")
        if t.val_psnr >= min(cfg.target_psnr, best.val_psnr - 0.1):
            reasons.append(f"{samples} samples per ray are enough ({t.val_psnr:.2f} dB)")
            best = t
        else:
            reasons.append(f"{samples} samples per ray lose quality ({t.val_psnr:.2f} dB): keep "
                           f"{best.recipe.model.render.n_coarse}")
            break
    if not spent():                                # view dependence has to earn its place
        t = trial(best.recipe.override(view_dependent=True), "view dependence")
        gain = t.val_psnr - best.val_psnr
        reasons.append(f"view dependence kept: +{gain:.2f} dB validation PSNR" if gain >= cfg.vd_gain else
                       f"view dependence dropped: it changed validation PSNR by {gain:+.2f} dB (< {cfg.vd_gain} dB)")
        best = t if gain >= cfg.vd_gain else best
    for key, weight in cfg.regularisers:           # so does each regulariser
        if spent():
            reasons.append(f"{key} not tried: the search budget is spent")
            continue
        t = trial(best.recipe.override(**{key: weight}), key)
        gain = t.val_psnr - best.val_psnr
        verb = "kept" if gain >= cfg.reg_gain else "dropped"
        reasons.append(f"{key} = {weight:g} {verb}: {gain:+.2f} dB validation PSNR (threshold {cfg.reg_gain} dB)")
        best = t if gain >= cfg.reg_gain else best
    return AutoResult(best.recipe, trials, reached, reasons)


def choose_recipe(dataset: Dataset, cfg: AutoConfig | None = None,
                  settings: dict | None = None) -> tuple[Recipe, list[str]]:
    """``fit --auto``: the smallest model that reaches the target, trained with its family's
    full recipe (budget and schedule) and then ``settings`` (what the user typed,
    :meth:`Recipe.override`); returns it and the reasons."""
    result = auto_size(dataset, cfg)
    chosen = recipe_for(result.recipe.model.field, dataset.dim)
    chosen.model.field_args.update(result.recipe.model.field_args)
    chosen.model.render.n_coarse = result.recipe.model.render.n_coarse
    for key, _ in (cfg or AutoConfig()).regularisers:
        setattr(chosen.train, key, getattr(result.recipe.train, key))
    chosen.name = f"auto:{chosen.name}"
    lines = [f"{t.recipe.model.field} ({', '.join(f'{k}={v}' for k, v in t.recipe.model.field_args.items())}), "
             f"{t.recipe.model.render.n_coarse} samples: {t.params} parameters, validation {round(t.val_psnr, 2)} dB "
             f"[{t.note}]" for t in result.trials]
    return chosen.override(**(settings or {})).validate(), lines + result.reasons
