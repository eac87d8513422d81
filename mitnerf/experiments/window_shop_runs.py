"""One training of the window-shopping ablation (:mod:`.window_shop`): the run's
specification, its model, and the measured row.

:func:`train_one` fits one :class:`Spec` and returns its CSV row (plus the first test
view, for the thumbnails). Nothing it meets stops the experiment: a run that raises
:class:`~mitnerf.train.trainer.TrainingFailed` (a NaN loss) is recorded as
``collapsed`` with the message as its ``reason``. Runs that finish are classified from
their test renders, so their PSNR, opacity and density stay on record as evidence:

* ``collapsed`` / ``empty``: mean predicted opacity on the object's pixels (ground-truth
  alpha > 0.5) below ``EMPTY_OPACITY``: the field let every ray through (the test views
  show only background);
* ``collapsed`` / ``constant``: the standard deviation of all test renders below 1e-3
  (the trainer's own collapse criterion, ``mitnerf.train.trainer._check_collapse``);
* otherwise ``ok``.

The trainer itself only checks for collapse on a validation split, so the ablation trains
without one (the split is dropped before :func:`~mitnerf.train.trainer.fit`): the
collapsed model survives and can be measured.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..data.dataset import Dataset
from ..train.metrics import psnr
from ..train.trainer import TrainingFailed, evaluate, fit

EMPTY_OPACITY = 0.1
"""Mean opacity on object pixels below which a run counts as collapsed to empty space."""
CONSTANT_STD = 1e-3
"""Standard deviation of the test renders below which a run counts as collapsed to a constant."""


@dataclass(frozen=True)
class Spec:
    """One training of the ablation."""

    object: str
    """3D scene name (``mitnerf.scenes.registry``)."""
    field: str
    """``vanilla`` (the ablated NeRF) or ``grid`` (our fast model, at its preset)."""
    budget: str
    """``iters`` (a fixed number of steps) or ``time`` (a fixed number of seconds)."""
    design: str
    """Why the run exists: ``views`` (base config on the views axis), ``ofat`` (one factor
    changed), ``factorial`` (``full=True``), ``probe`` (ReLU density) or ``grid``."""
    views: int
    """Training images (the first ``views`` of one random pool, so smaller sets are subsets)."""
    pos_L: int = 10
    """Positional-encoding frequencies L."""
    n_coarse: int = 64
    """Coarse samples per ray N_c."""
    view_dependent: bool = True
    """View direction fed to the colour branch."""
    hierarchical: bool = True
    """Fine pass of ``n_coarse * fine_ratio`` importance samples with its own field."""
    activation: str = "softplus"
    """Density activation (``relu`` is the original NeRF's)."""

    @property
    def name(self) -> str:
        if self.field != "vanilla":
            return f"{self.field} preset"
        parts = [f"L{self.pos_L}", f"Nc{self.n_coarse}", "vd" if self.view_dependent else "no-vd",
                 "hier" if self.hierarchical else "no-hier"]
        if self.activation != "softplus":
            parts.append(self.activation)
        return " ".join(parts)

    def model_key(self) -> tuple:
        """Identity of the model alone (what the compiled kernels depend on)."""
        return (self.field,) if self.field != "vanilla" else (
            self.field, self.pos_L, self.n_coarse, self.view_dependent, self.hierarchical, self.activation)

    def key(self) -> tuple:
        """Identity of the training (the design label aside)."""
        d = dataclasses.asdict(self)
        d.pop("design")
        if self.field != "vanilla":             # the grid ignores the NeRF hyperparameters
            d = {k: d[k] for k in ("object", "field", "budget", "views")}
        return tuple(sorted(d.items()))


def model_for(spec: Spec, cfg, background) -> tuple:
    """(ModelConfig, TrainConfig) of a run; ``cfg`` is the experiment's config."""
    from ..render.pipeline import RenderConfig
    from ..train.config import ModelConfig, TrainConfig
    from ..train.presets import preset

    if spec.field == "vanilla":
        n_fine = max(1, round(spec.n_coarse * cfg.fine_ratio)) if spec.hierarchical else 0
        mc = ModelConfig("vanilla", dict(width=cfg.width, depth=cfg.depth, pos_L=spec.pos_L, dir_L=cfg.dir_L,
                                         view_dependent=spec.view_dependent, density_activation=spec.activation),
                         RenderConfig(n_coarse=spec.n_coarse, n_fine=n_fine))
        tc = TrainConfig(batch_rays=cfg.batch_rays, lr=cfg.lr, lr_final=cfg.lr_final)
    else:
        mc, tc = preset(spec.field, 3)   # run for the budget: 200 steps end before its first upsampling
    mc.render.background = tuple(background)
    tc.iters = cfg.iters if spec.budget == "iters" else 1_000_000      # under a time budget the clock decides
    tc.time_budget = cfg.time_budget if spec.budget == "time" else None
    tc.val_every, tc.progress, tc.seed = 0, False, cfg.seed
    if spec.field == "vanilla":
        tc.warmup = cfg.warmup
    return mc, tc


def warm_up(spec: Spec, dataset: Dataset, cfg, steps: int = 3) -> float:
    """Compile the kernels of ``spec``'s model with a throw-away run of ``steps`` steps, so the
    timed run that follows pays for tracing only (Dr.Jit reuses compiled kernels by their
    content). A grid's later resolutions (coarse-to-fine) still compile inside the timed
    run. Returns the seconds it took."""
    import time

    mc, tc = model_for(spec, cfg, dataset.background)
    tc.iters, tc.time_budget = steps, None
    t0 = time.perf_counter()
    try:
        run = fit(dataset.sparse(), mc, tc)
        o, d = dataset["test"].cameras.subset(slice(0, 1)).rays()
        run.backend.render(o.reshape(-1, 3).astype(np.float32), d.reshape(-1, 3).astype(np.float32))
    except TrainingFailed:
        pass
    return time.perf_counter() - t0


def empty_psnr(dataset: Dataset, background) -> float:
    """PSNR of rendering nothing (background only) on the test views: the floor a run
    collapsed to empty space sits on."""
    target = dataset["test"].target(background)
    return psnr(np.broadcast_to(np.asarray(background, np.float32), target.shape), target)


def train_one(spec: Spec, dataset: Dataset, cfg) -> tuple[dict, dict | None]:
    """Fit ``spec`` on ``dataset`` (train and test splits) -> (CSV row, first test view or None)."""
    mc, tc = model_for(spec, cfg, dataset.background)
    nerf = spec.field == "vanilla"
    row = {**dataclasses.asdict(spec), "config": spec.name, "n_fine": mc.render.n_fine if nerf else "",
           "width": cfg.width if nerf else "", "batch_rays": tc.batch_rays, "seed": cfg.seed,
           "psnr_empty": empty_psnr(dataset, dataset.background)}
    data = dataset.sparse()
    try:
        run = fit(data, mc, tc)
    except TrainingFailed as exc:
        row.update(status="collapsed", reason=f"TrainingFailed: {exc}", psnr=math.nan, ssim=math.nan)
        return row, None
    test = dataset["test"]
    ev = evaluate(run, data, "test")
    r = ev["renders"]
    obj = test.alpha > 0.5                                                      # [n, H, W]
    op_fg = float(r["opacity"][obj].mean()) if obj.any() else math.nan
    op_bg = float(r["opacity"][~obj].mean()) if (~obj).any() else math.nan
    spread = float(np.std(r["rgb"]))
    if op_fg < EMPTY_OPACITY:
        status, reason = "collapsed", f"empty: mean opacity on the object {op_fg:.3f} < {EMPTY_OPACITY}"
    elif spread < CONSTANT_STD:
        status, reason = "collapsed", f"constant: render standard deviation {spread:.1e} < {CONSTANT_STD:g}"
    else:
        status, reason = "ok", ""
    grid = np.linspace(-1.0, 1.0, 24, dtype=np.float32)                         # the unit sphere's cube
    pts = np.stack(np.meshgrid(grid, grid, grid, indexing="ij"), -1).reshape(-1, 3)   # [24^3, 3]
    sigma = run.backend.density(pts)                                            # [24^3]
    row.update(status=status, reason=reason, psnr=ev["psnr"], ssim=ev["ssim"], depth_error=ev.get("depth_error"),
               train_time=run.train_time, steps=run.steps, ms_per_step=1000 * run.train_time / max(run.steps, 1),
               render_time=ev["render_time_per_view"], opacity_fg=op_fg, opacity_bg=op_bg,
               density_max=float(sigma.max()), density_mean=float(sigma.mean()))
    thumb = {"rgb": r["rgb"][0], "opacity": r["opacity"][0], "target": test.target(dataset.background)[0]}
    return row, thumb
