"""Stability: how often does training fail from sparse views, and what prevents it?

Every method of ``METHODS`` trains ``seeds`` times on the same sparse, evenly spaced views of one 2D
scene; a run fails as :func:`mitnerf.train.evaluate.classify` says. Two variants each switch one
safeguard off: ReLU, a zero density bias and no warm-up (dead density); the near plane 5 cm in
front of each camera (floaters). Writes ``stability.csv``, ``stability.png`` and ``report.md``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..data.cache import cached_dataset
from ..data.rig import RigConfig
from ..settings import setting
from ..train.recipes import get_recipe
from ..viz.panels import series_figure
from .claims import judged
from .report import markdown_table, summarise, train_row, write_csv, write_report

NERF = dict(width=32, depth=3, pos_L=8, dir_L=4)
# label -> (recipe, overrides, near plane override)
METHODS = {
    "NeRF (defaults)": ("vanilla-2d", NERF, None),
    "DS-NeRF (defaults)": ("vanilla-2d", {**NERF, "depth_weight": 0.02, "depth_sigma": 0.05}, None),
    "grid (defaults)": ("grid-2d", dict(resolution=129, initial_resolution=33, upsample_at=(50,)), None),
    "NeRF, ReLU + bias 0, no warm-up": ("vanilla-2d", {**NERF, "density_activation": "relu", "density_bias": 0.0,
                                                       "warmup": 0}, None),
    "NeRF, near plane at the camera": ("vanilla-2d", NERF, 0.05),
}


@dataclass
class Config:
    """The seed study."""

    scene: str = setting("bunny")
    """2D scene."""
    views: int = setting(5, lo=1, hi=100_000)
    """Evenly spaced training views (sparse)."""
    seeds: int = setting(20, lo=1, hi=10 ** 6)
    """Runs per method."""
    steps: int = setting(150, lo=1, hi=10 ** 9)
    """Training steps of every run."""
    samples: int = setting(48, lo=1, hi=4096)
    """Stratified samples per ray."""
    methods: tuple = setting(tuple(METHODS), choices=tuple(METHODS))
    """Which methods of ``METHODS`` to run."""
    seed: int = setting(0, lo=0, hi=2 ** 31)
    """Seed of the rig; run k of a method uses seed ``seed + k``."""
    quick: bool = setting(False)
    """A smoke run: its report judges nothing."""


def quick(seed: int = 0) -> Config:
    return Config(seeds=3, steps=40, samples=32, seed=seed, quick=True,
                  methods=("NeRF (defaults)", "NeRF, ReLU + bias 0, no warm-up"))


def run(cfg: Config, out: Path) -> list[dict]:
    ds = cached_dataset(cfg.scene, RigConfig(dim=2, n_train=cfg.views, n_val=4, n_test=20, layout="even",
                                             seed=cfg.seed))
    rows = []
    for label in cfg.methods:
        name, args, near = METHODS[label]
        data = ds if near is None else dataclasses.replace(ds, near=near)
        for k in range(cfg.seeds):
            recipe = get_recipe(name).at_steps(cfg.steps, **args, n_coarse=cfg.samples,
                                               val_every=max(cfg.steps // 3, 1), seed=cfg.seed + k)
            rows.append(train_row(data, recipe, {"method": label, "seed": cfg.seed + k}, geometry_metrics=False)[0])
    write_csv(out / "stability.csv", rows)
    summary = summarise(rows, ["method"], ("psnr",))
    at = {m: i for i, m in enumerate(cfg.methods)}               # every run at its method, jittered; failed at 5 dB
    runs = [{"x": at[r["method"]] + j, "psnr": r["psnr"] if r["status"] == "ok" else 5.0,
             "run": "ok" if r["status"] == "ok" else "failed"}
            for r, j in zip(rows, np.random.default_rng(0).uniform(-0.15, 0.15, len(rows)))]
    ticks = dict(xticks=list(at.values()), xticklabels=[m.replace(", ", ",\n") for m in at], xlabel="")
    series_figure(out / "stability.png", [
        dict(rows=runs, x="x", by=("run",), styles={"ok": "o", "failed": "rx"}, err=False, **ticks),
        dict(rows=[{"x": at[s["method"]], **s} for s in summary], x="x", y="failure_rate", styles={None: "rs"},
             err=False, ylabel="failure rate", **ticks)],
        f"{cfg.scene}, {cfg.views} views, {cfg.seeds} seeds per method, {cfg.steps} steps", cell=(6, 3.8))
    table = markdown_table(summary, ["method", "runs", "failed", "failure_rate", "psnr_median", "psnr_p10",
                                     "psnr_p90", "failures"], {k: ".2f" for k in ("failure_rate", "psnr_median",
                                                                                 "psnr_p10", "psnr_p90")},
                           {"psnr_median": "median", "psnr_p10": "p10", "psnr_p90": "p90"})
    write_report(out, f"Stability from {cfg.views} views of the {cfg.scene}", [
        ("Setup", f"{cfg.seeds} seeds per method (initial weights, batches, jitter; the views are fixed), "
                  f"{cfg.steps} steps, {cfg.samples} samples per ray, {cfg.views} evenly spaced training views, "
                  "20 test views. Failed: NaN, or collapsed (empty or constant renders; "
                  "`mitnerf.train.evaluate.classify`)."),
        ("Results", table + "\n![PSNR per run and failure rates](stability.png)"),
    ], cfg.quick, lambda: judged("stability", rows))
    return rows
