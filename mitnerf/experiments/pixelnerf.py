"""pixelNeRF in 2D against NeRF with 1, 3, 5 and 9 input views (NeRF2D's experiment).

pixelNeRF (the ``pixelnerf-2d`` recipe) trains on procedural outlines plus ``extra_scenes``, once
per encoder. On ``eval_scenes`` (never trained on), for every ``k`` and draw, pixelNeRF reads ``k``
views and a ``vanilla-2d`` NeRF trains on exactly them; both are scored on the same noise-free test
views. Writes ``results.csv``, ``training.csv``, ``psnr_vs_views.png``, ``strips_<scene>.png``,
``density_<scene>.png``, ``training.png`` and ``report.md``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..data.cache import cached_dataset
from ..data.generate import make_dataset
from ..data.rig import RigConfig, noise_preset
from ..fields.pixelnerf import PixelNeRFConfig
from ..scenes.procedural import outline_scene
from ..scenes.registry import get_scene
from ..settings import setting
from ..train.metrics import depth_error, psnr, ssim
from ..train.pixelnerf import PixelTrainer, pick_views, scene_views
from ..train.recipes import get_recipe
from ..viz.panels import density_panel, image_grid, series_figure, strip_panel
from .claims import judged
from .report import markdown_table, mean_std, summarise, train_row, write_csv, write_report


@dataclass
class Config:
    """Sizes and budgets (defaults: the full run, whose time `mitnerf experiment all` records)."""

    n_outlines: int = setting(48, lo=0, hi=10 ** 6)
    """Procedural outlines pixelNeRF is trained on."""
    extra_scenes: tuple = setting(("square", "square_concave"))
    """Named scenes added to the training set (never bunny or tu: they are the test)."""
    train_views: int = setting(24, lo=1, hi=100_000)
    """Random noisy views per training scene."""
    outline_test_views: int = setting(8, lo=1, hi=100_000)
    """Evenly spaced test views per outline."""
    n_seen: int = setting(4, lo=0, hi=10 ** 6)
    """Training outlines whose held-out views are scored."""
    n_unseen: int = setting(4, lo=0, hi=10 ** 6)
    """Outlines never trained on, scored like the training ones."""
    eval_scenes: tuple = setting(("bunny", "tu"), selects=True)
    """Scenes pixelNeRF never sees in training; NeRF is fitted to them."""
    eval_train_views: int = setting(40, lo=1, hi=100_000)
    """Views of each evaluation scene from which the ``k`` inputs are picked."""
    eval_test_views: int = setting(16, lo=1, hi=100_000)
    """Evenly spaced, noise-free test views of each evaluation scene."""
    ks: tuple = setting((1, 3, 5, 9), lo=1, hi=100_000, selects=True)
    """Numbers of input views compared."""
    draws: int = setting(3, lo=1, hi=10 ** 6)
    """Input-view draws per (scene, k): the spread of every figure."""
    encoders: tuple = setting(("frozen", "trained"), choices=("frozen", "trained"), selects=True)
    """pixelNeRF variants."""
    model: PixelNeRFConfig = field(default_factory=PixelNeRFConfig)
    """pixelNeRF architecture (``encoder`` is set per variant)."""
    k_range: tuple = setting((1, 9), lo=1, hi=100_000)
    """Input views per pixelNeRF training step, drawn from this inclusive range."""
    pixel_iters: int | None = setting(None, lo=1, hi=10 ** 9)
    """pixelNeRF steps per variant (None: the recipe's)."""
    pixel_budget: float | None = setting(None, lo=0, above=True, hi=10 ** 7)
    """pixelNeRF seconds per variant (None: the recipe's)."""
    nerf_iters: int = setting(1000, lo=1, hi=10 ** 9)
    """Steps of each NeRF baseline."""
    nerf_batch_rays: int = setting(256, lo=1, hi=1 << 22)
    """Rays per NeRF step (1 to 9 views hold 100 to 900 rays)."""
    nerf_time_budget: float = setting(60.0, lo=0, above=True, hi=10 ** 7)
    """Seconds of each NeRF baseline at most."""
    seed: int = setting(0, lo=0, hi=2 ** 31)
    """Seed of the outlines, the rigs and the trainings."""
    quick: bool = setting(False)
    """A smoke run: its report judges nothing."""


def quick(seed: int = 0) -> Config:
    return Config(n_outlines=12, n_seen=2, n_unseen=2, eval_test_views=8, draws=1, pixel_iters=4000,
                  pixel_budget=22.0, nerf_iters=200, nerf_time_budget=4.0, seed=seed, quick=True)


def rig(n_train: int, n_test: int, seed: int) -> RigConfig:
    return RigConfig(dim=2, n_train=n_train, n_val=0, n_test=n_test, resolution=100, seed=seed, **noise_preset(1.0))


def outline(cfg: Config, i: int):
    s = 1000 * cfg.seed + i
    return make_dataset(outline_scene(s), rig(cfg.train_views, cfg.outline_test_views, s), progress=False)


def picks(ds, k: int, draw: int, draws: int) -> np.ndarray:
    """The ``k`` input views of draw ``draw`` (each draw starts the even spread at another camera)."""
    return pick_views(ds["train"].cameras, k, start=draw * len(ds["train"]) // max(draws, 1))


def panels(rows: list[dict]) -> list[dict]:
    """The charts of its rows (:func:`~mitnerf.viz.panels.series_figure`): test PSNR against the input views on each
    evaluation scene, then on the seen and the unseen outlines."""
    s = summarise([{**r, "panel": r["scene"] if r["group"] == "eval" else r["group"]} for r in rows],
                  ["panel", "method", "k"], ("psnr",))
    return [dict(title=f"pixelNeRF: {p}", rows=[r for r in s if r["panel"] == p], x="k", by=("method",),
                 xlabel="input views k", xticks=sorted({r["k"] for r in s}))
            for p in dict.fromkeys(r["panel"] for r in s)]


def run(cfg: Config, out: Path) -> list[dict]:
    outlines = [outline(cfg, i) for i in range(cfg.n_outlines)]
    unseen = [outline(cfg, 500 + i) for i in range(cfg.n_unseen)]
    evals = {n: cached_dataset(n, dataclasses.replace(rig(cfg.eval_train_views, cfg.eval_test_views, 100 + cfg.seed),
                                                      n_val=2)) for n in cfg.eval_scenes}
    train_sets = [scene_views(ds, name=f"outline{i}") for i, ds in enumerate(outlines)]
    train_sets += [scene_views(make_dataset(get_scene(n), rig(cfg.train_views, 0, 77 + j), progress=False), name=n)
                   for j, n in enumerate(cfg.extra_scenes)]
    recipe = get_recipe("pixelnerf-2d").override(iters=cfg.pixel_iters, time_budget=cfg.pixel_budget, seed=cfg.seed)
    rows, history, renders, densities, trainers = [], [], {}, {}, {}
    for enc in cfg.encoders:
        t = PixelTrainer(dataclasses.replace(cfg.model, encoder=enc), recipe.copy(), train_sets, cfg.k_range).train()
        trainers[enc] = t
        history += [{"encoder": enc, "step": s, "time": tt, "loss": v} for s, tt, v in
                    zip(t.state.history["step"], t.state.history["time"], t.state.history["loss"])]
        method = f"pixelNeRF ({enc})"
        jobs = [(n, ds, "eval") for n, ds in evals.items()] + [(f"seen{i}", ds, "seen outline") for i, ds in
                                                               enumerate(outlines[:cfg.n_seen])]
        jobs += [(f"unseen{i}", ds, "unseen outline") for i, ds in enumerate(unseen)]
        for name, ds, group in jobs:
            test = ds["test"]
            target, (o, d) = test.target(ds.background), test.cameras.rays()
            for k in cfg.ks:
                for draw in range(cfg.draws if group == "eval" else 1):
                    ctx = scene_views(ds).context(t.field, picks(ds, k, draw, cfg.draws))
                    pred = {key: v.reshape(*o.shape[:-1], *v.shape[1:]) for key, v in
                            t.render(ctx, o.reshape(-1, 2), d.reshape(-1, 2), ds.near, ds.far).items()}
                    rows.append({"method": method, "scene": name, "group": group, "k": k, "draw": draw,
                                 "psnr": psnr(pred["rgb"], target), "ssim": ssim(pred["rgb"], target),
                                 "depth_error": depth_error(pred["depth"], pred["opacity"], test.depth, test.mask),
                                 "status": "ok", "train_time": t.state.train_time, "steps": t.state.step})
                    if group == "eval" and draw == 0:
                        renders[(name, k, method)] = pred["rgb"]
                        densities[(name, k, method)] = t.density(ctx)
    for name, ds in evals.items():
        for k in cfg.ks:
            for draw in range(cfg.draws):
                nerf = get_recipe("vanilla-2d").override(iters=cfg.nerf_iters, time_budget=cfg.nerf_time_budget,
                                                        batch_rays=cfg.nerf_batch_rays, val_every=0, seed=draw)
                labels = {"method": "NeRF", "scene": name, "group": "eval", "k": k, "draw": draw}
                row, r, rec = train_row(ds.sparse(picks(ds, k, draw, cfg.draws)), nerf, labels)
                rows.append(row)
                if draw == 0:
                    renders[(name, k, "NeRF")], densities[(name, k, "NeRF")] = rec.renders["rgb"], r.backend.density
    write_csv(out / "results.csv", rows)
    write_csv(out / "training.csv", history)
    methods = [f"pixelNeRF ({e})" for e in cfg.encoders] + ["NeRF"]
    _draw(cfg, rows, history, renders, densities, evals, methods, out)
    _write(cfg, rows, trainers, methods, out)
    return rows


def _draw(cfg, rows, history, renders, densities, evals, methods, out) -> None:
    """``psnr_vs_views.png`` (per evaluation scene, then the seen and the unseen outlines), per evaluation scene
    ``strips_<scene>.png`` and ``density_<scene>.png`` (a row per method, a column per k), ``training.png``."""
    series_figure(out / "psnr_vs_views.png", panels(rows), cell=(3.6, 3.4))
    for name, ds in evals.items():
        target = ds["test"].target(ds.background)
        image_grid(out / f"strips_{name}.png", [[(strip_panel, target, f"ground truth, k = {k}") for k in cfg.ks]] + [
            [(strip_panel, renders[(name, k, m)], f"{m}, k = {k}") for k in cfg.ks] for m in methods], cell=(4, 1.2))
        image_grid(out / f"density_{name}.png", [[(density_panel, densities[(name, k, m)], ds.bound,
                                                   ds.meta.get("polygon"), f"{m}, k = {k}", 96) for m in methods]
                                                 for k in cfg.ks], cell=(2.6, 2.5), dpi=90)
    series_figure(out / "training.png", [dict(rows=history, x="time", y="loss", by=("encoder",), err=False,
                                              styles={e: "-" for e in cfg.encoders}, yscale="log",
                                              xlabel="training time [s]", ylabel="MSE")], cell=(5.5, 3.4))


def _write(cfg, rows, trainers, methods, out) -> None:
    summary = summarise(rows, ["group", "scene", "method", "k"], ("psnr", "ssim"))
    ev = {(s["scene"], s["method"], s["k"]): s for s in summary if s["group"] == "eval"}
    table = [{"scene": n, "method": m, **{f"k={k}": mean_std(ev[(n, m, k)], "psnr") for k in cfg.ks}}
             for n in cfg.eval_scenes for m in methods]
    diff = [{"scene": n, "pixelNeRF - NeRF": m, **{f"k={k}": format(ev[(n, m, k)]["psnr"] - ev[(n, "NeRF", k)]["psnr"],
                                                                   "+.2f") for k in cfg.ks}}
            for n in cfg.eval_scenes for m in methods[:-1]]
    gen = [{"method": m, "scenes": g, **{f"k={k}": mean_std(s, "psnr") for k in cfg.ks
                                         for s in summary if s["method"] == m and s["group"] == g and s["k"] == k}}
           for m in methods[:-1] for g in ("seen outline", "unseen outline")]
    steps = "; ".join(f"{e}: {t.state.step} steps in {t.state.train_time:.0f} s" for e, t in trainers.items())
    write_report(out, "pixelNeRF in 2D against NeRF with few views", [
        ("Set-up", f"pixelNeRF trained on {cfg.n_outlines} procedural outlines and "
                   f"{', '.join(cfg.extra_scenes) or 'no'} named scenes ({cfg.train_views} noisy views each; recipe "
                   f"`pixelnerf-2d`: {steps}). Scored on "
                   f"{', '.join(cfg.eval_scenes)} (never trained on): the k of {cfg.eval_train_views} views nearest "
                   f"an even spread, {cfg.draws} draw(s) per k, {cfg.eval_test_views} test views. NeRF: recipe "
                   f"`vanilla-2d`, {cfg.nerf_iters} steps or {cfg.nerf_time_budget:g} s of {cfg.nerf_batch_rays} rays "
                   "on exactly the k views."),
        ("PSNR against the number of input views", "Test PSNR [dB] (mean ± std over draws):\n\n"
         + markdown_table(table) + "\nDifference of the means to NeRF [dB] (nan: NeRF failed):\n\n"
         + markdown_table(diff) + "\n![PSNR vs views](psnr_vs_views.png)"),
        ("Generalisation", "pixelNeRF on held-out views of training outlines and on unseen outlines:\n\n"
         + markdown_table(gen)),
        ("Test views", "\n".join(f"![{n}](strips_{n}.png)\n\n![density {n}](density_{n}.png)\n"
                                 for n in cfg.eval_scenes) + "\n![training loss](training.png)"),
    ], cfg.quick, lambda: judged("pixelnerf", rows))
