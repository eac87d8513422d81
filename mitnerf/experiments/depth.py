"""Depth supervision (DS-NeRF) against plain NeRF from sparse views (NeRF2D's experiment).

Per scene and number of evenly spaced training views, the ``vanilla-2d`` recipe trains ``seeds``
times with the photometric loss only (NeRF) and with DS-NeRF's depth loss added (``depth_weight`` x
the KL divergence of :mod:`mitnerf.train.losses`, on the exact pixel-centre depths). Writes
``depth.csv``, ``depth_<scene>.png``, ``depth_summary.png`` and ``report.md``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..data.cache import cached_dataset
from ..data.rig import RigConfig
from ..settings import setting
from ..train.recipes import get_recipe
from ..viz.panels import density_panel, depth_panel, image_grid, series_figure, strip_panel
from .claims import judged
from .report import markdown_table, mean_std, summarise, train_row, write_csv, write_report

METHODS = (("NeRF", False), ("DS-NeRF", True))


@dataclass
class Config:
    """The NeRF / DS-NeRF comparison."""

    scenes: tuple = setting(("square", "square_concave", "bunny", "tu"), selects=True)
    """2D scenes (NeRF2D's four)."""
    views: tuple = setting((2, 5, 10), lo=1, hi=100_000, selects=True)
    """Numbers of evenly spaced training views."""
    width: int = setting(32, lo=2, hi=1024)
    """MLP width."""
    depth: int = setting(4, lo=1, hi=32)
    """MLP layers."""
    pos_L: int = setting(8, lo=0, hi=24)
    """Position frequencies."""
    samples: int = setting(64, lo=1, hi=4096)
    """Stratified samples per ray."""
    steps: int = setting(500, lo=1, hi=10 ** 9)
    """Training steps of every run."""
    batch_rays: int = setting(512, lo=1, hi=1 << 22)
    """Rays per step (2 to 10 views hold only 200-1000 rays)."""
    depth_weight: float = setting(0.02, lo=0, hi=1e6)
    """lambda: weight of the depth loss."""
    depth_sigma: float = setting(0.05, lo=0, above=True, hi=1e6)
    """sigma-hat: width of the target termination distribution (world units)."""
    seeds: int = setting(2, lo=1, hi=10 ** 6)
    """Runs per (scene, views, method)."""
    seed: int = setting(0, lo=0, hi=2 ** 31)
    """Seed of the rigs and of the first run."""
    quick: bool = setting(False)
    """A smoke run: its report judges nothing."""


def quick(seed: int = 0) -> Config:
    return Config(scenes=("square_concave",), views=(3,), width=16, depth=3, pos_L=6, samples=32, steps=120,
                  seeds=1, seed=seed, quick=True)


def panels(rows: list[dict]) -> list[dict]:
    """The charts of its rows (:func:`~mitnerf.viz.panels.series_figure`): test PSNR and depth error against the
    training views, per scene and method."""
    s = summarise(rows, ["scene", "views", "method"], ("psnr", "depth_error"))
    return [dict(title="depth supervision", rows=s, x="views", y=y, by=("scene", "method"), ylabel=label,
                 styles={"NeRF": "o--", "DS-NeRF": "s-"}, xlabel="training views")
            for y, label in (("psnr", "test PSNR [dB]"), ("depth_error", "test depth error"))]


def run(cfg: Config, out: Path) -> list[dict]:
    rows = []
    for scene in cfg.scenes:
        grid = []
        for k in cfg.views:
            ds = cached_dataset(scene, RigConfig(dim=2, n_train=k, n_val=4, n_test=20, layout="even", seed=cfg.seed))
            for method, supervised in METHODS:
                for s in range(cfg.seeds):
                    recipe = get_recipe("vanilla-2d").at_steps(
                        cfg.steps, width=cfg.width, depth=cfg.depth, pos_L=cfg.pos_L, n_coarse=cfg.samples,
                        batch_rays=cfg.batch_rays, val_every=0, seed=cfg.seed + s,
                        depth_weight=cfg.depth_weight if supervised else 0.0, depth_sigma=cfg.depth_sigma)
                    row, r, rec = train_row(ds.sparse(), recipe, {"scene": scene, "views": k, "method": method,
                                                                  "seed": cfg.seed + s})
                    rows.append(row)
                    if s == 0:
                        p = rec.renders
                        grid.append([(strip_panel, p["rgb"], f"{method}, {k} views: PSNR {rec.psnr:.1f}"),
                                       (depth_panel, p["depth"], p["opacity"], ds.near, ds.far,
                                        f"depth error {rec.depth_error:.3f}"),
                                       (density_panel, r.backend.density, ds.bound, ds.meta.get("polygon"), "density")])
        image_grid(out / f"depth_{scene}.png", [[(strip_panel, ds["test"].target(ds.background), f"{scene}: ground "
                                                 "truth"), (depth_panel, ds["test"].depth, None, ds.near, ds.far,
                                                            "true depth")]] + grid, cell=(3, 1.25))
    write_csv(out / "depth.csv", rows)
    series_figure(out / "depth_summary.png", panels(rows), cell=(5, 3.4))
    summary = summarise(rows, ["scene", "views", "method"], ("psnr", "depth_error", "iou"))
    table = [{**{k: s[k] for k in ("scene", "views", "method", "runs")}, "PSNR": mean_std(s, "psnr"),
              "depth error": mean_std(s, "depth_error", ".3f"), "IoU": mean_std(s, "iou", ".3f")} for s in summary]
    figs = "\n\n".join(f"### {s}\n\n![{s}](depth_{s}.png)" for s in cfg.scenes)
    write_report(out, "Depth supervision (DS-NeRF) from sparse views", [
        ("Setup", f"Recipe `vanilla-2d` at {cfg.width} x {cfg.depth}, L = {cfg.pos_L}, {cfg.samples} samples per "
                  f"ray, {cfg.steps} steps of {cfg.batch_rays} rays, {cfg.seeds} seed(s); training views evenly "
                  f"spaced (a random rotation), 20 evenly spaced test views. DS-NeRF adds lambda = {cfg.depth_weight} "
                  f"x KL(N(D, {cfg.depth_sigma}^2) || h) over the rays that hit the object, D the exact depth."),
        ("Results", markdown_table(table) + "\n![PSNR and depth error](depth_summary.png)"),
        ("Figures", "Each grid: ground truth on top, then each method and view count: test views, test depth "
                    "(where opacity > 0.5) and the density with the true outline.\n\n" + figs),
    ], cfg.quick, lambda: judged("depth", rows))
    return rows
