"""Let the data choose the model, from probe runs judged at the budget the model will train for.

:func:`auto_size` trains each candidate (:func:`candidates`: the default recipe as the data sizes it, first, so
that a search the budget cuts short still has it to choose; then, in 3D, its lattice coarser, and ``LADDER``'s,
each its family's recipe, options included, with the candidate's size, smallest first) for ``probe_time``
seconds of the clock, so a faster model's extra steps count as they will in the real run; the score is PSNR on at
most ``val_pixels`` pixels of validation views. The chosen size is the smallest candidate within ``tolerance`` dB
of the best probe, or, with ``target_psnr``, the smallest to reach it. Then half the samples per ray are tried, and
view dependence, the view harmonics' degree (down to 1) and each regulariser are switched the other way from the
recipe, one at a time: a switch is taken only where it gains ``vd_gain`` / ``reg_gain`` dB of validation PSNR, so
the recipe's tuned setting stands where a few validation views cannot tell the two apart. The scene is switched
first, the same way (:data:`OTHER_SCENE`: a forward-facing capture tried as unbounded, an unbounded one as an object
in a box). Data without validation views (real captures hold out only test views) lends the probes every 8th
training view from the 5th (:func:`with_validation`); the chosen recipe then trains on all of them. Every trial and
every decision's reason is kept."""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..data.dataset import Dataset
from ..fields import FIELDS, field_config
from .fit import fit
from .recipes import GRID_DIVISIONS, LADDER, Recipe, recipe_for

OTHER_SCENE = {"forward": "unbounded", "unbounded": "object"}
"""The scene ``fit --auto`` tries against each (an object with alpha has no other)."""
PINNED = ("density_refine",)
"""Settings the user types with ``fit --auto`` that shape how each probe is sized, not only the chosen recipe:
every probe of a family that has them takes them (:func:`pinned_for`)."""


def pinned_for(family: str, settings: dict | None) -> dict:
    """The :data:`PINNED` ones of ``settings`` that ``family``'s fields have."""
    own = FIELDS[family][0].__dataclass_fields__
    return {k: v for k, v in (settings or {}).items() if k in PINNED and k in own}


@dataclass
class AutoConfig:
    """The search."""

    probe_time: float | None = None
    """Seconds of training per probe, and the budget of the chosen recipe; None: the user's ``--time-budget``
    (``choose_recipe``'s settings), else the default recipe's budget for the dataset's dimension."""
    steps: int | None = None
    """If set, each probe takes this many steps instead (a deterministic search; the chosen recipe keeps its
    family's budget)."""
    tolerance: float = 0.3
    """A candidate within this many dB of the best probe is good enough; the smallest such is chosen."""
    target_psnr: float | None = None
    """If set, the smallest probed candidate to reach this validation PSNR is chosen: after the default, the others
    run smallest first and the first to reach it ends the search for a size."""
    time_budget: float = 300.0
    """Seconds for the whole search, checked between probes; past it, the best candidate so far is returned."""
    val_pixels: int = 1 << 20
    """Pixels of validation views each probe is scored on at most: views evenly spread, at least one (every view
    of 100 x 100, six of 400 x 400)."""
    families: tuple = ("grid", "vanilla", "hashgrid", "hashlinear")
    """Field families to consider."""
    vd_gain: float = 0.2
    """Minimum validation-PSNR gain (dB) for switching view dependence the other way from the recipe, or for
    lowering its harmonics to degree 1."""
    regularisers: tuple = ("tv_color_weight", "distortion_weight", "opacity_weight")
    """Training or field settings tried one at a time on the chosen model, where its family has the setting; one
    that the model has off is switched on at :func:`regulariser_weights`' weight."""
    reg_gain: float = 0.2
    """Minimum validation-PSNR gain (dB) for switching a regulariser the other way from the recipe."""
    seed: int = 0
    """Seed of every probe."""
    scene: str = "object"
    """The scene the data shows (``mitnerf.render.space.pick_scene``), whose recipes the probes start from."""
    scene_gain: float = 0.2
    """Minimum validation-PSNR gain (dB) for switching the scene to :data:`OTHER_SCENE`'s."""


@dataclass
class Trial:
    recipe: Recipe
    params: int
    val_psnr: float
    train_time: float
    note: str = ""
    trained: Recipe | None = None
    """The recipe as the probe trained it (sized for the data: what :func:`trial_line` shows); None: ``recipe``."""


@dataclass
class AutoResult:
    recipe: Recipe
    trials: list = field(default_factory=list)
    reached: bool = False
    reasons: list = field(default_factory=list)

    @property
    def model(self):
        return self.recipe.model


def regulariser_weights(cfg: AutoConfig, dim: int) -> list[tuple[str, float]]:
    """``(setting, weight)`` of each of ``cfg.regularisers``: the weight the dimension's default recipe is tuned
    with (in 3D, where 25 views see each point from few directions, a colour total variation as strong as 2D's
    smooths away the highlights; ``fit_table.py``'s 3D rows measure it)."""
    default = recipe_for(None, dim)
    return [(key, default.get(key)) for key in cfg.regularisers]


def probe_seconds(cfg: AutoConfig, dim: int) -> float:
    return cfg.probe_time or recipe_for(None, dim, cfg.scene).train.time_budget


def with_validation(dataset: Dataset) -> tuple[Dataset, str]:
    """``dataset`` with a validation split, and what was done: as it is where it has one, else with every 8th
    training view from the 5th (at least one) moved to validation."""
    if dataset.splits.get("val"):
        return dataset, ""
    n = len(dataset["train"])
    held = np.arange(4 % n, n, 8)
    splits = dict(dataset.splits, train=dataset["train"].subset(np.setdiff1d(np.arange(n), held)),
                  val=dataset["train"].subset(held))
    return Dataset(splits, dataset.near, dataset.far, dict(dataset.meta)), (
        f"the data has no validation views: the probes validate on training views {', '.join(map(str, held))} "
        f"(every 8th from the 5th) and train on the other {n - len(held)}; the chosen recipe trains on all {n}")


def probe_recipe(family: str, args: dict, dataset: Dataset, cfg: AutoConfig, pinned: dict | None = None) -> Recipe:
    """The family's recipe (its view dependence and losses included) with the candidate's settings and the user's
    ``pinned`` ones (:func:`pinned_for`), trained for :func:`probe_seconds` (or ``cfg.steps`` steps) with one
    validation, on ``cfg.val_pixels`` pixels' worth of ``dataset``'s validation views."""
    base = recipe_for(family, dataset.dim, cfg.scene)
    cams = dataset["val"].cameras
    kw = dict(args, **pinned_for(family, pinned), seed=cfg.seed, val_every=0,
              val_views=max(1, cfg.val_pixels // (cams.width * cams.height)), progress=False)
    if cfg.steps:
        return base.at_steps(cfg.steps, **kw)
    return base.override(**kw, time_budget=probe_seconds(cfg, dataset.dim), iters=10 ** 6)


def final_params(family: str, args: dict, dim: int) -> int:
    """Parameters of a candidate at the end of its training (a grid at its final resolution, a linearly decoded
    hash grid with all its levels): what its size is judged by."""
    cfg = field_config(family, **args, dim=dim).final()
    return sum(v.size for v in FIELDS[family][1](cfg).init_numpy(0).values())


def candidates(dataset: Dataset, cfg: AutoConfig, pinned: dict | None = None) -> list[tuple[str, dict]]:
    """``(family, settings)`` of the probes in the order they run: the scene's default recipe as it stands (``{}``:
    :func:`~.fit.fit` sizes it from the data); in 3D, that lattice with :data:`GRID_DIVISIONS` times fewer spacings
    (coarse to fine with the same doublings, their density refined as the default's), none under 3 a side,
    smallest first; then ``LADDER``'s candidates, smallest (:func:`final_params`, as sized for ``dataset``) first;
    of ``cfg.families`` only; each as ``pinned`` sizes it (:func:`probe_recipe`)."""
    default = recipe_for(None, dataset.dim, cfg.scene)
    family = default.model.field
    default = default.override(**pinned_for(family, pinned))
    args, coarser = default.sized(dataset).model.field_args, []
    if dataset.dim == 3 and "resolution" in args:    # the sized lattice's first spacings, c, divided by k
        c = (args.get("initial_resolution") or args["resolution"]) - 1
        step = (args["resolution"] - 1) // c
        refine = {"density_refine": args["density_refine"]} if "density_refine" in args else {}  # as its density
        coarser = [(family, dict(resolution=c // k * step + 1, initial_resolution=c // k + 1, **refine))
                   for k in sorted(GRID_DIVISIONS, reverse=True) if c // k >= 2]
    size = lambda c: final_params(c[0], probe_recipe(*c, dataset, cfg, pinned).sized(dataset).model.field_args,
                                  dataset.dim)
    ours = lambda cands: sorted((c for c in cands if c[0] in cfg.families), key=size)
    return [(family, {})] * (family in cfg.families) + ours(coarser) + ours(LADDER[dataset.dim])


def pick_size(sized: list[Trial], tolerance: float, target: float | None = None) -> tuple[Trial, bool, str]:
    """``(chosen, reached, why)`` of size probes listed smallest first: the first to reach ``target`` when
    one is given (else the best), otherwise the first within ``tolerance`` dB of the best."""
    top = max(sized, key=lambda t: t.val_psnr)
    name = lambda t: f"{t.recipe.model.field}, {t.params} parameters, {t.val_psnr:.2f} dB"
    if target is not None:
        first = next((t for t in sized if t.val_psnr >= target), None)
        return ((first, True, f"the smallest candidate to reach {target:.1f} dB") if first else
                (top, False, f"the best candidate: none reached {target:.1f} dB within the search budget"))
    first = next(t for t in sized if t.val_psnr >= top.val_psnr - tolerance)
    return first, True, (f"the best of {len(sized)} probes" if first is top else
                         f"the smallest within {tolerance} dB of the best probe ({name(top)})")


def switch(now: bool, gain: float, need: float) -> tuple[bool, str]:
    """Whether to switch an option away from the recipe's setting ``now``, the switch gaining ``gain`` dB of
    validation PSNR, and the word for the outcome (``dropped``/``added`` or ``kept``/``left off``)."""
    take = gain >= need
    return take, ("dropped" if now else "added") if take else ("kept" if now else "left off")


def untried(what: str, kept: str) -> str:
    """The reason line of a probe the spent search budget leaves out."""
    return f"{what} not tried: the search budget is spent ({kept})"


def trial_line(t: Trial) -> str:
    """One probe as ``fit --auto`` prints it: the settings it trained with."""
    r = (t.trained or t.recipe).model
    shown = lambda v: (f"{v:.4g}" if isinstance(v, float) else f"({', '.join(map(shown, v))})"
                       if isinstance(v, tuple) else str(v))
    args = ", ".join(f"{k}={shown(v)}" for k, v in r.field_args.items())
    return (f"{r.field} ({args}), {r.render.n_coarse} samples: {t.params} parameters, validation "
            f"{round(t.val_psnr, 2)} dB in {t.train_time:.1f} s [{t.note}]")


def auto_size(dataset: Dataset, cfg: AutoConfig | None = None, say=None, pinned: dict | None = None) -> AutoResult:
    """The chosen model and its options; see the module docstring. ``say(line)`` hears of each probe as it ends;
    ``pinned``: the user's :data:`PINNED` settings, which every probe takes."""
    cfg = cfg or AutoConfig()
    t0 = time.perf_counter()
    spent = lambda: time.perf_counter() - t0 > cfg.time_budget
    dataset, held = with_validation(dataset)
    cands = candidates(dataset, cfg, pinned)
    trials: list[Trial] = []

    def trial(recipe: Recipe, note: str) -> Trial:
        run = fit(dataset, recipe, "drjit", progress=False)
        val = run.state.history["val_psnr"]
        trials.append(Trial(recipe, run.backend.n_params(), val[-1] if val else -math.inf, run.state.train_time, note,
                            run.recipe))
        if say is not None:
            say(trial_line(trials[-1]))
        return trials[-1]

    sized: list[Trial] = []
    for family, args in cands:
        if spent() and sized:                     # the default at least, whatever the budget
            break
        sized.append(trial(probe_recipe(family, args, dataset, cfg, pinned), "size"))
        if args and cfg.target_psnr is not None and sized[-1].val_psnr >= cfg.target_psnr:     # not the default
            break
    best, reached, why = pick_size(sorted(sized, key=lambda t: t.params), cfg.tolerance, cfg.target_psnr)
    reasons = [held] * bool(held) + [f"{best.recipe.model.field} with {best.params} parameters "
                                     f"({best.val_psnr:.2f} dB) is {why}"]
    other = OTHER_SCENE.get(cfg.scene)
    if other is not None and spent():
        reasons.append(untried(f"the {other} scene", f"kept the {cfg.scene} scene"))
    elif other is not None:
        t = trial(best.recipe.override(scene=other), "scene")
        gain = t.val_psnr - best.val_psnr
        take = gain >= cfg.scene_gain
        reasons.append(f"the {cfg.scene} scene {'switched to' if take else 'kept against'} {other}: {other} gains "
                       f"{gain:+.2f} dB validation PSNR (needs {cfg.scene_gain} dB)")
        best = t if take else best
    samples = best.recipe.model.render.n_coarse // 2          # fewer samples: faster steps, more of them
    if samples >= 16 and spent():
        reasons.append(untried(f"{samples} samples per ray", f"kept {best.recipe.model.render.n_coarse}"))
    elif samples >= 16:
        t = trial(best.recipe.override(n_coarse=samples), "samples")
        enough = t.val_psnr >= best.val_psnr - 0.1
        reasons.append(f"{samples} samples per ray " + (f"are enough ({t.val_psnr:.2f} dB)" if enough else
                       f"lose quality ({t.val_psnr:.2f} dB): keep {best.recipe.model.render.n_coarse}"))
        best = t if enough else best
    options = ([("view_dependent", True, cfg.vd_gain), ("sh_degree", 1, cfg.vd_gain)]
               + [(k, w, cfg.reg_gain) for k, w in regulariser_weights(cfg, dataset.dim)])
    for key, on, need in options:                  # a switch away from the recipe has to earn its place
        if not best.recipe.has(key):
            continue
        now = best.recipe.get(key)
        if key == "sh_degree":                     # a lower degree of view harmonics, where there are any above 1
            if not best.recipe.get("view_dependent") or now <= on:
                continue
            label, new, note, how = f"view harmonics of degree {now}", on, "degree", f"degree {on}"
        else:
            label = "view dependence" if key == "view_dependent" else f"{key} = {now or on:g}"
            new, note = type(on)(0) if now else on, key.replace("view_dependent", "view dependence")
            how = f"switching it {'off' if now else 'on'}"
        if spent():
            reasons.append(untried(label, "left as in the recipe"))
            continue
        t = trial(best.recipe.override(**{key: new}), note)
        gain = t.val_psnr - best.val_psnr
        take, verdict = switch(bool(now), gain, need)        # a degree above 1 counts as on: dropped or kept
        reasons.append(f"{label} {verdict}: {how} gains {gain:+.2f} dB validation PSNR (needs {need} dB)")
        best = t if take else best
    return AutoResult(best.recipe, trials, reached, reasons)


def choose_recipe(dataset: Dataset, cfg: AutoConfig | None = None, settings: dict | None = None,
                  say=None) -> tuple[Recipe, list[str]]:
    """``fit --auto``: the winning probe's recipe with its family's validation and seed settings, then ``settings``
    (what the user typed, :meth:`Recipe.override`); returns it and the reasons (the probes' lines too, unless
    ``say`` heard each as it ended). It trains for the probes' budget (the user's ``time_budget`` when typed), or
    its family's when the probes count steps."""
    settings = dict(settings or {})
    cfg = copy.copy(cfg or AutoConfig())
    settings.pop("scene", None)                     # cfg.scene: the scene the search starts from
    if settings.get("time_budget") and not cfg.probe_time:
        cfg.probe_time = float(settings["time_budget"])
    result = auto_size(dataset, cfg, say, settings)
    won = result.recipe.model                     # the winning probe, less what only probes set
    base = recipe_for(won.field, dataset.dim, won.render.scene)
    own = base.train
    chosen = result.recipe.override(val_every=own.val_every, val_views=own.val_views, seed=own.seed,
                                    progress=own.progress,
                                    **(dict(iters=own.iters, time_budget=own.time_budget) if cfg.steps else {}))
    chosen.name = f"auto:{base.name}"
    lines = [] if say is not None else [trial_line(t) for t in result.trials]
    return chosen.override(**settings).validate(), lines + result.reasons
