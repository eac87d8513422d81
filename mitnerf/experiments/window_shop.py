"""Experiment ``window-shop``: how few photos of a product does a NeRF need, and which of
its hyperparameters matter? The ablation of the original window-shopping report, on CPU.

**The report's claims.** A vanilla NeRF fitted to a product from 5, 10, 25 or 100 photos,
ablating positional encoding L in {6, 10}, coarse samples N_c in {64, 128}, view
dependence on/off and hierarchical sampling on/off: "PSNR stays around 23-25 dB even at
5 views; N_c = 128 with 5 views collapsed to 15-16 dB".

**Protocol.**

* Objects ``vase`` and ``nut`` (``objects``), unit sphere, white background. One pool of
  ``pool_views`` random, slightly noisy training photos on the upper hemisphere
  (``noise_preset(1.0)``) per object; a run with N views trains on the first N, so
  5 views are a subset of 10, of 25, of 100. Test: ``test_views`` noise-free views on the
  360 degree orbit at 25 degrees (the buyer's view). Images are ``resolution`` pixels
  square (50x50 by default: the MLP's cost per step does not depend on the image size,
  but evaluating does, and every pixel of 100 views at 100x100 is 1M rays).
* The NeRF (``field='vanilla'``) is narrower than the original (``width`` x ``depth``
  ReLU trunk, 32 x 3, instead of 256 x 8): on 2 CPU cores a step of the full-size model
  costs seconds. Hierarchical sampling adds ``N_c * fine_ratio`` importance samples with a
  separate fine field; "off" renders the N_c stratified samples only.
* Two budgets per configuration: ``iters`` steps (every run the same number of steps,
  so costlier configurations take longer) and ``time_budget`` seconds (the learning-rate
  schedule follows the clock; costlier configurations take fewer steps).
* **Default design** (16.4 min with 2 cores to itself, load average ~2; 23.7 min at load ~4
  with a 15 s time budget): one factor at a time around the
  base configuration (L = 10, N_c = 64, view dependence on, hierarchical on), each
  factor changed alone at ``ofat_views`` (5: where the report saw the collapse); plus the
  base configuration at every number of views; plus our fast model (the dense grid at
  its preset, :func:`mitnerf.train.presets.preset`, run for the budget: 200 steps end
  before its first upsampling, so the fixed-iteration rows train a 33^3 grid; compressing
  the schedule into 200 steps was measured worse, 20.7 against 23.0 dB on the vase at 5
  views) at every number of views and both budgets; plus a probe
  with the original NeRF's ReLU density (base and N_c = 128 at ``probe_views``, fixed
  iterations), since our NeRF defaults to softplus. That is
  2 x (4 + 4) x 2 = 32 NeRF runs, 16 grid runs, 4 probes.
* ``full=True``: the whole factorial, 4 x 2 x 2 x 2 x 2 = 64 configurations x 2 budgets
  x 2 objects = 256 NeRF trainings (plus grid and probes): hours on a CPU.
* ``quick=True``: one object, 24x24 images, 5 and 25 views, two factors, 40 steps or 3 s
  (~1 min; its numbers only show that everything runs).

Every run is classified (:mod:`.window_shop_runs`): ``collapsed`` if training raised
``TrainingFailed``, or the field is empty on the object, or its renders are constant;
``ok`` otherwise. Outputs (:mod:`.window_shop_report`): ``results.csv``, ``table.md``,
``psnr_vs_time.png``, ``psnr_vs_views.png``, ``thumbnails.png`` and ``report.md``.
"""

from __future__ import annotations

import itertools
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

from tqdm.auto import tqdm

from .window_shop_runs import Spec, train_one, warm_up

BASE = dict(pos_L=10, n_coarse=64, view_dependent=True, hierarchical=True)
"""The base configuration (NeRF's own choices)."""
LEVELS = dict(pos_L=(6, 10), n_coarse=(64, 128), view_dependent=(True, False), hierarchical=(True, False))
"""Levels of each factor of the report's grid."""


@dataclass
class WindowShopConfig:
    """Sizes and budgets (defaults: the default run, ~15 minutes on 2 idle cores)."""

    objects: tuple = ("vase", "nut")
    """3D objects of ours."""
    resolution: int = 50
    """Image width and height in pixels."""
    pool_views: int = 100
    """Training photos rendered per object; a run uses the first ``views`` of them."""
    test_views: int = 8
    """Noise-free test views on the 25 degree orbit."""
    views: tuple = (5, 10, 25, 100)
    """Numbers of training photos (the base configuration and the grid run at each)."""
    factors: tuple = ("pos_L", "n_coarse", "view_dependent", "hierarchical")
    """Factors changed one at a time (their non-base levels from ``LEVELS``)."""
    ofat_views: tuple = (5,)
    """Numbers of views at which each factor is changed."""
    full: bool = False
    """Run the whole factorial (views x all factors) instead of one factor at a time."""
    budgets: tuple = ("iters", "time")
    """``iters``: every run takes ``iters`` steps; ``time``: every run takes ``time_budget`` s."""
    iters: int = 200
    """Steps of the fixed-iteration budget."""
    time_budget: float = 20.0
    """Seconds of the fixed-time budget."""
    width: int = 32
    """NeRF trunk width."""
    depth: int = 3
    """NeRF trunk layers."""
    dir_L: int = 4
    """View-direction encoding frequencies."""
    fine_ratio: float = 0.5
    """Fine samples per coarse sample when hierarchical (N_f = N_c * fine_ratio)."""
    batch_rays: int = 512
    """Rays per NeRF step (the grid uses its preset's)."""
    lr: float = 1e-2
    """NeRF peak learning rate (twice the preset's: at 150 steps on the vase, 25 views, 16.9 dB
    against 12.9 dB with 5e-3)."""
    lr_final: float = 1e-3
    """NeRF final learning rate."""
    warmup: int = 20
    """NeRF steps of linear learning-rate warm-up (the trainer's default, 50, would be most of a
    short run: a 15 s budget gave the base ~76 steps on a busy machine)."""
    compile_first: bool = True
    """Before the first timed run of each model, compile its kernels with a 3-step throw-away
    run, so train times measure training rather than the JIT compiler."""
    grid: bool = True
    """Also train the dense grid (our fast model) at every number of views."""
    probe_views: tuple = (5,)
    """Views at which the ReLU-density probe runs (empty: no probe)."""
    probe_n_coarse: tuple = (64, 128)
    """N_c of the ReLU probes (fixed-iteration budget, other factors at base)."""
    seed: int = 0
    """Seed of the photos' placement, the weights, the batches."""
    progress: bool = True
    """A progress bar over the runs."""
    extras: dict = field(default_factory=dict)
    """Free-form notes copied into the report (e.g. why a setting was changed)."""


def quick_config(seed: int = 0) -> WindowShopConfig:
    """< 2 minutes: the vase, 24x24 images, 5 and 25 views, two factors, 40 steps or 3 s."""
    return WindowShopConfig(objects=("vase",), resolution=24, pool_views=25, test_views=4, views=(5, 25),
                            factors=("n_coarse", "hierarchical"), iters=40, time_budget=3.0, warmup=10,
                            probe_n_coarse=(128,), seed=seed)


def design(cfg: WindowShopConfig) -> list[Spec]:
    """Every run of the experiment, duplicates removed, grouped by object."""
    specs: list[Spec] = []
    for obj, budget in itertools.product(cfg.objects, cfg.budgets):
        mk = lambda design, views, **kw: Spec(obj, "vanilla", budget, design, views, **{**BASE, **kw})
        if cfg.full:
            names = list(LEVELS)
            for views, *levels in itertools.product(cfg.views, *(LEVELS[n] for n in names)):
                specs.append(mk("factorial", views, **dict(zip(names, levels))))
        else:
            specs += [mk("views", v) for v in cfg.views]
            for name in cfg.factors:
                for level in LEVELS[name]:
                    if level != BASE[name]:
                        specs += [mk("ofat", v, **{name: level}) for v in cfg.ofat_views]
        if cfg.grid:
            specs += [Spec(obj, "grid", budget, "grid", v) for v in cfg.views]
        if budget == "iters":
            specs += [mk("probe", v, n_coarse=nc, activation="relu")
                      for v in cfg.probe_views for nc in cfg.probe_n_coarse]
    seen, unique = set(), []
    for s in sorted(specs, key=lambda s: cfg.objects.index(s.object)):    # stable: design order per object
        if s.key() not in seen:
            seen.add(s.key())
            unique.append(s)
    return unique


def photos(obj: str, cfg: WindowShopConfig):
    """The object's dataset: ``pool_views`` training photos and the test orbit."""
    from ..data.rig import RigConfig, noise_preset
    from .common import cached_dataset

    rig = RigConfig(dim=3, n_train=max(cfg.pool_views, max(cfg.views)), n_val=1, n_test=cfg.test_views,
                    resolution=cfg.resolution, seed=cfg.seed, **noise_preset(1.0))
    return cached_dataset(obj, rig)


def execute(out: Path, cfg: WindowShopConfig) -> Path:
    """Run the design of ``cfg`` and write every output into ``out``; returns ``report.md``."""
    from .window_shop_report import write_outputs

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    specs = design(cfg)
    rows, thumbs, data, compiled = [], {}, {}, set()
    loads = [os.getloadavg()[0]]                       # 1-minute load average: how busy the cores were
    t0 = time.perf_counter()
    with tqdm(total=len(specs), desc="window-shop", unit="run", disable=not cfg.progress) as bar:
        for spec in specs:
            bar.set_postfix_str(f"{spec.object} {spec.views}v {spec.name} [{spec.budget}]", refresh=True)
            if spec.object not in data:
                data = {spec.object: photos(spec.object, cfg)}                  # one object in memory at a time
            photos_n = data[spec.object].sparse(slice(0, spec.views))
            if cfg.compile_first and spec.model_key() not in compiled:
                warm_up(spec, photos_n, cfg)
                compiled.add(spec.model_key())
            row, thumb = train_one(spec, photos_n, cfg)
            rows.append(row)
            if thumb is not None:
                thumbs[spec] = thumb
            loads.append(os.getloadavg()[0])
            bar.update()
    wall = time.perf_counter() - t0
    return write_outputs(out, rows, thumbs, cfg, wall, (min(loads), max(loads)))


def run(out: Path, quick: bool = False, seed: int = 0, full: bool = False) -> Path:
    """The experiment (``python -m mitnerf experiment window-shop --out DIR [--quick]``).
    ``full=True`` runs the whole factorial (hours); ``quick`` wins over ``full`` (the CLI
    refuses both at once)."""
    cfg = quick_config(seed) if quick else WindowShopConfig(seed=seed, full=full)
    return execute(Path(out), cfg)


