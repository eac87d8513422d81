"""Positional encoding: how many frequencies does the vanilla NeRF need? (NeRF2D's experiment)

The ``vanilla-2d`` recipe trains with L position frequencies for every L in ``Ls`` (L = 0: the raw
coordinates), ``seeds`` times each. Writes ``pe.csv``, ``pe_psnr.png``, ``pe_density.png``,
``pe_views.png`` and ``report.md``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..data.cache import cached_dataset
from ..data.rig import RigConfig, noise_preset
from ..settings import setting
from ..train.recipes import get_recipe
from ..viz.panels import density_panel, image_grid, series_figure, strip_panel
from .claims import judged
from .report import markdown_table, mean_std, summarise, train_row, write_csv, write_report


@dataclass
class Config:
    """The positional-encoding sweep."""

    Ls: tuple = setting((0, 1, 2, 4, 6, 8, 10), lo=0, hi=24, selects=True)
    """Position frequencies to compare."""
    scene: str = setting("bunny")
    """2D scene."""
    n_train: int = setting(50, lo=1, hi=100_000)
    """Training views (random, noisy: the NeRF2D protocol)."""
    width: int = setting(32, lo=2, hi=1024)
    """MLP width."""
    depth: int = setting(4, lo=1, hi=32)
    """MLP layers."""
    samples: int = setting(64, lo=1, hi=4096)
    """Stratified samples per ray."""
    steps: int = setting(1000, lo=1, hi=10 ** 9)
    """Training steps of every run."""
    batch_rays: int = setting(512, lo=1, hi=1 << 22)
    """Rays per step."""
    lr: float = setting(1e-2, lo=0, above=True, hi=10)
    """Initial learning rate (decays to 1/25 of it)."""
    seeds: int = setting(2, lo=1, hi=10 ** 6)
    """Runs per L (seeds ``seed .. seed + seeds - 1``)."""
    seed: int = setting(0, lo=0, hi=2 ** 31)
    """Seed of the rig and of the first run."""
    quick: bool = setting(False)
    """A smoke run: its report judges nothing."""


def quick(seed: int = 0) -> Config:
    return Config(Ls=(0, 2, 8), n_train=20, width=16, depth=3, samples=32, steps=120, seeds=1, seed=seed, quick=True)


def panels(rows: list[dict]) -> list[dict]:
    """The charts of its rows (:func:`~mitnerf.viz.panels.series_figure`): test PSNR and train time against L."""
    s = summarise(rows, ["L"], ("psnr", "train_time"))
    return [dict(title="positional encoding", rows=s, x="L", xlabel="position frequencies L"),
            dict(title="positional encoding", rows=s, x="L", y="train_time", err=False, xlabel="position frequencies L",
                 ylabel="train time [s]")]


def run(cfg: Config, out: Path) -> list[dict]:
    ds = cached_dataset(cfg.scene, RigConfig(dim=2, n_train=cfg.n_train, n_val=4, n_test=20, seed=cfg.seed,
                                             **noise_preset(1.0)))
    rows, firsts = [], {}
    for L in cfg.Ls:
        for k in range(cfg.seeds):
            recipe = get_recipe("vanilla-2d").at_steps(cfg.steps, width=cfg.width, depth=cfg.depth, pos_L=L,
                                                      n_coarse=cfg.samples, batch_rays=cfg.batch_rays, lr=cfg.lr,
                                                      lr_final=cfg.lr / 25, val_every=0, seed=cfg.seed + k)
            row, r, rec = train_row(ds, recipe, {"L": L, "seed": cfg.seed + k})
            rows.append(row)
            if k == 0:
                firsts[L] = (r.backend.density, rec.renders["rgb"])
    write_csv(out / "pe.csv", rows)
    summary = summarise(rows, ["L"], ("psnr", "ssim", "iou", "train_time"))
    series_figure(out / "pe_psnr.png", panels(rows),
                  f"{cfg.scene}: vanilla {cfg.width} x {cfg.depth}, {cfg.steps} steps, {cfg.seeds} seed(s)")
    image_grid(out / "pe_density.png", [[(density_panel, firsts[L][0], ds.bound, ds.meta.get("polygon"), f"L = {L}")
                                         for L in cfg.Ls]], cell=(2.2, 2.4))
    image_grid(out / "pe_views.png", [[(strip_panel, ds["test"].target(ds.background), "ground truth")]]
               + [[(strip_panel, firsts[L][1], f"L = {L}")] for L in cfg.Ls], cell=(6, 1.1))
    table = [{"L": s["L"], "runs": s["runs"], "failed": s["failed"], "PSNR": mean_std(s, "psnr"),
              "SSIM": mean_std(s, "ssim", ".3f"), "IoU": mean_std(s, "iou", ".3f"),
              "train s": f"{s['train_time']:.1f}"} for s in summary]
    write_report(out, f"Positional encoding on the {cfg.scene}", [
        ("Setup", f"Recipe `vanilla-2d` at {cfg.width} x {cfg.depth}, {cfg.samples} stratified samples per ray, "
                  f"{cfg.steps} steps of {cfg.batch_rays} rays (lr {cfg.lr:g}), {cfg.seeds} seed(s) per L; "
                  f"{cfg.n_train} noisy training views of 100 px, 20 evenly spaced test views. L = 0 feeds the raw "
                  "coordinates (no encoding)."),
        ("Results", markdown_table(table) + "\n![PSNR and train time against L](pe_psnr.png)"),
        ("Density fields", "The density on the plane (log scale); the true outline in cyan.\n\n"
                           "![density per L](pe_density.png)\n\n![test views per L](pe_views.png)"),
    ], cfg.quick, lambda: judged("pe", rows))
    return rows
