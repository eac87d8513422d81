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
from ..train.recipes import get_recipe
from ..viz.panels import pyplot, save
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

    scene: str = "bunny"
    """2D scene."""
    views: int = 5
    """Evenly spaced training views (sparse)."""
    seeds: int = 20
    """Runs per method."""
    steps: int = 150
    """Training steps of every run."""
    samples: int = 48
    """Stratified samples per ray."""
    methods: tuple = tuple(METHODS)
    """Which methods of ``METHODS`` to run."""
    seed: int = 0
    """Seed of the rig; run k of a method uses seed ``seed + k``."""


def quick(seed: int = 0) -> Config:
    return Config(seeds=3, steps=40, samples=32, seed=seed,
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
    for s in summary:
        p = np.array([r["psnr"] for r in rows if r["method"] == s["method"] and r["status"] == "ok"])
        s["failure_rate"] = s["failed"] / s["runs"]
        s["median"], s["p10"], s["p90"] = (np.median(p), *np.percentile(p, [10, 90])) if len(p) else (np.nan,) * 3
        s["failures"] = "; ".join(sorted({r["reason"].split(";")[0].split(" (")[0] for r in rows
                                          if r["method"] == s["method"] and r["status"] != "ok"})) or "-"
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8), gridspec_kw={"width_ratios": [3, 1]})
    for i, label in enumerate(cfg.methods):
        rs = [r for r in rows if r["method"] == label]
        jitter = np.random.default_rng(i).uniform(-0.15, 0.15, len(rs))
        ok = [(i + j, r["psnr"]) for j, r in zip(jitter, rs) if r["status"] == "ok"]
        bad = [i + j for j, r in zip(jitter, rs) if r["status"] != "ok"]
        if ok:
            axes[0].plot(*zip(*ok), "o", ms=4, alpha=0.7)
        if bad:
            axes[0].plot(bad, [5.0] * len(bad), "x", color="red", ms=6)
    axes[0].set_xticks(range(len(cfg.methods)), [m.replace(", ", ",\n") for m in cfg.methods], fontsize=7)
    axes[0].set_ylabel("test PSNR [dB] (x: failed)")
    axes[0].grid(alpha=0.3, axis="y")
    axes[1].barh(range(len(summary)), [s["failure_rate"] for s in summary], color="tab:red")
    axes[1].set_yticks(range(len(summary)), [s["method"] for s in summary], fontsize=6)
    axes[1].set(xlabel="failure rate", xlim=(0, 1))
    fig.suptitle(f"{cfg.scene}, {cfg.views} views, {cfg.seeds} seeds per method, {cfg.steps} steps")
    save(fig, out / "stability.png")
    by = {s["method"]: s for s in summary}
    lines = []
    base, relu = by.get("NeRF (defaults)"), by.get("NeRF, ReLU + bias 0, no warm-up")
    near = by.get("NeRF, near plane at the camera")
    if base and relu:
        lines.append("- **Dead density.** With ReLU, a zero density bias and no warm-up, "
                     f"{relu['failed']}/{relu['runs']} runs failed ({relu['failures']}); with the defaults (softplus "
                     "density, which always has a gradient; a -1 density bias; a 50-step warm-up) "
                     f"{base['failed']}/{base['runs']}.")
    if base and near:
        lines.append(f"- **Floaters in front of the cameras.** With the near plane 5 cm in front of the cameras the "
                     f"median test PSNR is {near['median']:.2f} dB against {base['median']:.2f} dB with the near plane "
                     "at the object's bounding circle (the datasets' default).")
    for s in [by[label] for label in ("DS-NeRF (defaults)", "grid (defaults)") if label in by]:
        lines.append(f"- **{s['method']}**: {s['failed']}/{s['runs']} failed; median {s['median']:.2f} dB "
                     f"(10-90 %: {s['p10']:.2f}-{s['p90']:.2f}).")
    table = markdown_table(summary, ["method", "runs", "failed", "failure_rate", "median", "p10", "p90", "failures"],
                           fmt={"failure_rate": ".2f", "median": ".2f", "p10": ".2f", "p90": ".2f"})
    write_report(out, f"Stability from {cfg.views} views of the {cfg.scene}", [
        ("Setup", f"{cfg.seeds} seeds per method (initial weights, batches, jitter; the views are fixed), "
                  f"{cfg.steps} steps, {cfg.samples} samples per ray, {cfg.views} evenly spaced training views, "
                  "20 test views. Failed: NaN, or collapsed (empty or constant renders; "
                  "`mitnerf.train.evaluate.classify`)."),
        ("Results", table + "\n![PSNR per run and failure rates](stability.png)"),
        ("Failure modes and what prevents them", "\n".join(lines)),
    ])
    return rows
