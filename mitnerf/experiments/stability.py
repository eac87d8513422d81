"""Stability: how often does training fail from sparse views, and what prevents it?

Every method trains from ``seeds`` seeds (weights, batches and jitter differ; the
sparse, evenly spaced views stay the same) on one 2D scene; the test PSNR of each run
is kept, and a run counts as *collapsed* when the trainer stops it (NaN loss, or
constant renders at a validation) or its final test renders are constant.

Methods: the defaults (vanilla NeRF, DS-NeRF, the dense grid), and variants that switch
one safeguard off to show the failure mode it prevents:

* ``NeRF, ReLU + bias 0, no warm-up``: NeRF's original density activation and
  initialisation at our learning rate, without the warm-up: if the density outputs
  all go negative early, ReLU's gradient is zero and the field stays empty ("dead"
  density: constant background renders).
* ``NeRF, near plane at the camera``: samples start 5 cm in front of each camera instead
  of at the object's bounding circle: with few views the field can explain each
  image with floaters right in front of its camera, which test views see through.

``python -m mitnerf experiment stability --out DIR [--quick]`` writes
``stability.csv``, ``stability.png`` (test PSNR per run and method, collapses marked;
collapse rates) and ``report.md``.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..data.rig import RigConfig
from ..render.pipeline import RenderConfig
from ..train.config import ModelConfig, TrainConfig
from .common import cached_dataset, markdown_table, train_eval, write_csv, write_report

NERF = dict(width=32, depth=3, pos_L=8, dir_L=4)

# label -> (field, field_args, train overrides, near plane override)
METHODS = {
    "NeRF (defaults)": ("vanilla", NERF, {}, None),
    "DS-NeRF (defaults)": ("vanilla", NERF, {"depth_weight": 0.02, "depth_sigma": 0.05}, None),
    "grid (defaults)": ("grid", dict(resolution=129, initial_resolution=33, upsample_at=(50,), tv_weight=1e-4),
                        {"lr": 0.05, "lr_final": 0.005}, None),
    "NeRF, ReLU + bias 0, no warm-up": ("vanilla", {**NERF, "density_activation": "relu", "density_bias": 0.0},
                                        {"warmup": 0}, None),
    "NeRF, near plane at the camera": ("vanilla", NERF, {}, 0.05),
}


@dataclass
class StabilityConfig:
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

    @classmethod
    def quick(cls, seed: int = 0) -> "StabilityConfig":
        return cls(seeds=3, steps=40, samples=32, seed=seed,
                   methods=("NeRF (defaults)", "NeRF, ReLU + bias 0, no warm-up"))


def run_stability(cfg: StabilityConfig, out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .figures import save

    out.mkdir(parents=True, exist_ok=True)
    ds = cached_dataset(cfg.scene, RigConfig(dim=2, n_train=cfg.views, n_val=4, n_test=20, layout="even",
                                             seed=cfg.seed))
    rows = []
    for label in cfg.methods:
        field, args, train, near = METHODS[label]
        data = ds
        if near is not None:
            data = copy.copy(ds)
            data.near = near
        for k in range(cfg.seeds):
            mc = ModelConfig(field, dict(args), RenderConfig(n_coarse=cfg.samples))
            tc = TrainConfig(iters=cfg.steps, val_every=max(cfg.steps // 3, 1), val_views=4, progress=False,
                             seed=cfg.seed + k, **train)
            _, row = train_eval(data, mc, tc)
            rows.append({"method": label, "seed": cfg.seed + k, **row})
    write_csv(out / "stability.csv", rows)

    summary = []
    for label in cfg.methods:
        rs = [r for r in rows if r["method"] == label]
        ok = np.array([r["psnr"] for r in rs if r["status"] == "ok"])
        errors = sorted({r.get("error", "").split(";")[0] for r in rs if r["status"] != "ok"})
        summary.append({"method": label, "runs": len(rs), "collapsed": len(rs) - len(ok),
                        "collapse_rate": (len(rs) - len(ok)) / max(len(rs), 1),
                        "median_psnr": float(np.median(ok)) if len(ok) else float("nan"),
                        "p10_psnr": float(np.percentile(ok, 10)) if len(ok) else float("nan"),
                        "p90_psnr": float(np.percentile(ok, 90)) if len(ok) else float("nan"),
                        "failures": "; ".join(e for e in errors if e) or "-"})

    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8), gridspec_kw={"width_ratios": [3, 1]})
    for i, label in enumerate(cfg.methods):
        rs = [r for r in rows if r["method"] == label]
        jitter = np.random.default_rng(i).uniform(-0.15, 0.15, len(rs))
        ok = [(i + j, r["psnr"]) for j, r in zip(jitter, rs) if r["status"] == "ok"]
        bad = [i + j for j, r in zip(jitter, rs) if r["status"] != "ok"]
        if ok:
            axes[0].plot(*zip(*ok), "o", ms=4, alpha=0.7)
        if bad:
            axes[0].plot(bad, [axes[0].get_ylim()[0] if ok else 5.0] * len(bad), "x", color="red", ms=6)
    axes[0].set_xticks(range(len(cfg.methods)), [m.replace(", ", ",\n") for m in cfg.methods], fontsize=7)
    axes[0].set_ylabel("test PSNR [dB] (x: collapsed)")
    axes[0].grid(alpha=0.3, axis="y")
    axes[1].barh(range(len(summary)), [s["collapse_rate"] for s in summary], color="tab:red")
    axes[1].set_yticks(range(len(summary)), [s["method"] for s in summary], fontsize=6)
    axes[1].set_xlabel("collapse rate")
    axes[1].set_xlim(0, 1)
    fig.suptitle(f"{cfg.scene}, {cfg.views} views, {cfg.seeds} seeds per method, {cfg.steps} steps")
    save(fig, out / "stability.png")

    table = markdown_table(summary, ["method", "runs", "collapsed", "collapse_rate", "median_psnr", "p10_psnr",
                                     "p90_psnr", "failures"],
                           fmt={"collapse_rate": ".2f", "median_psnr": ".2f", "p10_psnr": ".2f", "p90_psnr": ".2f"})
    return write_report(out, f"Stability from {cfg.views} views of the {cfg.scene}", [
        ("Setup", f"{cfg.seeds} seeds per method (initial weights, batches and sample jitter; the views are "
                  f"fixed), {cfg.steps} steps, {cfg.samples} samples per ray, {cfg.views} evenly spaced "
                  "training views, 20 test views. A run is *collapsed* when the trainer stops it (NaN loss, "
                  "constant renders at a validation) or its final test renders are constant."),
        ("Results", table + "\n![PSNR per run and collapse rates](stability.png)"),
        ("Failure modes and what prevents them", _failure_text(summary)),
    ])


def _failure_text(summary) -> str:
    by = {s["method"]: s for s in summary}
    lines = []
    base = by.get("NeRF (defaults)")
    relu = by.get("NeRF, ReLU + bias 0, no warm-up")
    near = by.get("NeRF, near plane at the camera")
    if base and relu:
        lines.append(f"- **Dead density (activation, initialisation, warm-up).** With ReLU, a zero density bias and "
                     f"no warm-up, {relu['collapsed']}/{relu['runs']} runs collapsed ({relu['failures']}); with the "
                     f"defaults (softplus density, which always has a gradient; a -1 density bias, so that the field "
                     f"starts transparent but alive; a 50-step linear warm-up of the learning rate) "
                     f"{base['collapsed']}/{base['runs']}.")
    if base and near:
        lines.append(f"- **Floaters in front of the cameras (near plane).** With the near plane 5 cm in front of "
                     f"the cameras the median test PSNR is {near['median_psnr']:.2f} dB against "
                     f"{base['median_psnr']:.2f} dB with the near plane at the object's bounding circle (the "
                     "datasets' default): the field can paint each sparse view on a veil close to its camera. "
                     "Keep the near plane at the scene bound.")
    for label in ("DS-NeRF (defaults)", "grid (defaults)"):
        if label in by:
            s = by[label]
            lines.append(f"- **{label}**: {s['collapsed']}/{s['runs']} collapsed; median {s['median_psnr']:.2f} dB "
                         f"(10-90 %: {s['p10_psnr']:.2f}-{s['p90_psnr']:.2f}).")
    lines.append("- Loss NaN: DS-NeRF's log(w / delta) met intervals of zero length (a jittered last sample that "
                 "rounded onto the far plane); the loss now skips them (`tests/test_losses.py`).")
    return "\n".join(lines)


def run(out: Path, quick: bool = False, seed: int = 0) -> Path:
    return run_stability(StabilityConfig.quick(seed) if quick else StabilityConfig(seed=seed), Path(out))
