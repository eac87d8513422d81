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
from ..train.metrics import depth_error, psnr, ssim
from ..train.pixelnerf import PixelTrainer, pick_views, scene_views
from ..train.recipes import get_recipe
from ..viz.panels import density_panel, pyplot, save
from ..viz.strips import views_strip
from .report import markdown_table, mean_std, summarise, train_row, write_csv, write_report


@dataclass
class Config:
    """Sizes and budgets (defaults: the full run, whose time `mitnerf experiment all` records)."""

    n_outlines: int = 48
    """Procedural outlines pixelNeRF is trained on."""
    extra_scenes: tuple = ("square", "square_concave")
    """Named scenes added to the training set (never bunny or tu: they are the test)."""
    train_views: int = 24
    """Random noisy views per training scene."""
    outline_test_views: int = 8
    """Evenly spaced test views per outline."""
    n_seen: int = 4
    """Training outlines whose held-out views are scored."""
    n_unseen: int = 4
    """Outlines never trained on, scored like the training ones."""
    eval_scenes: tuple = ("bunny", "tu")
    """Scenes pixelNeRF never sees in training; NeRF is fitted to them."""
    eval_train_views: int = 40
    """Views of each evaluation scene from which the ``k`` inputs are picked."""
    eval_test_views: int = 16
    """Evenly spaced, noise-free test views of each evaluation scene."""
    ks: tuple = (1, 3, 5, 9)
    """Numbers of input views compared."""
    draws: int = 3
    """Input-view draws per (scene, k): the spread of every figure."""
    encoders: tuple = ("frozen", "trained")
    """pixelNeRF variants."""
    model: PixelNeRFConfig = field(default_factory=PixelNeRFConfig)
    """pixelNeRF architecture (``encoder`` is set per variant)."""
    k_range: tuple = (1, 9)
    """Input views per pixelNeRF training step, drawn from this inclusive range."""
    pixel_iters: int | None = None
    """pixelNeRF steps per variant (None: the recipe's)."""
    pixel_budget: float | None = None
    """pixelNeRF seconds per variant (None: the recipe's)."""
    nerf_iters: int = 1000
    """Steps of each NeRF baseline."""
    nerf_batch_rays: int = 256
    """Rays per NeRF step (1 to 9 views hold 100 to 900 rays)."""
    nerf_time_budget: float = 60.0
    """Seconds of each NeRF baseline at most."""
    seed: int = 0
    """Seed of the outlines, the rigs and the trainings."""


def quick(seed: int = 0) -> Config:
    return Config(n_outlines=12, n_seen=2, n_unseen=2, eval_test_views=8, draws=1, pixel_iters=4000,
                  pixel_budget=22.0, nerf_iters=200, nerf_time_budget=4.0, seed=seed)


def tiny(seed: int = 0) -> Config:
    """The smallest run that writes every file (the test suite)."""
    return Config(n_outlines=2, extra_scenes=(), train_views=6, outline_test_views=4, n_seen=1, n_unseen=1,
                  eval_scenes=("bunny",), eval_train_views=8, eval_test_views=4, ks=(1, 3), draws=1, k_range=(1, 3),
                  model=PixelNeRFConfig(channels=8, dilations=(1, 2), width=32), pixel_iters=10, nerf_iters=8,
                  seed=seed)


def rig(n_train: int, n_test: int, seed: int) -> RigConfig:
    return RigConfig(dim=2, n_train=n_train, n_val=0, n_test=n_test, resolution=100, seed=seed, **noise_preset(1.0))


def outline(cfg: Config, i: int):
    s = 1000 * cfg.seed + i
    return make_dataset(outline_scene(s), rig(cfg.train_views, cfg.outline_test_views, s), progress=False)


def picks(ds, k: int, draw: int, draws: int) -> np.ndarray:
    """The ``k`` input views of draw ``draw`` (each draw starts the even spread at another camera)."""
    return pick_views(ds["train"].cameras, k, start=draw * len(ds["train"]) // max(draws, 1))


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
    summary = summarise(rows, ["group", "scene", "method", "k"], ("psnr", "ssim"))
    _figures_and_report(cfg, summary, history, renders, densities, evals, trainers, methods, out)
    return rows


def _figures_and_report(cfg, summary, history, renders, densities, evals, trainers, methods, out) -> None:
    plt = pyplot()
    panels = list(cfg.eval_scenes) + ["seen outline", "unseen outline"]
    fig, axes = plt.subplots(1, len(panels), figsize=(3.6 * len(panels), 3.4), squeeze=False)
    for ax, panel in zip(axes[0], panels):
        for m in methods:
            pts = [(s["k"], s["psnr"], s["psnr_std"]) for s in summary if s["method"] == m and
                   (s["scene"] == panel if panel in cfg.eval_scenes else s["group"] == panel)]
            if pts:
                ks = sorted({p[0] for p in pts})
                y = [np.mean([p[1] for p in pts if p[0] == k]) for k in ks]
                e = [np.mean([p[2] for p in pts if p[0] == k]) for k in ks]
                ax.errorbar(ks, y, yerr=e, fmt="o-", capsize=2, label=m)
        ax.set(title=panel, xlabel="input views k", xticks=list(cfg.ks))
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("test PSNR [dB]")
    axes[0][0].legend(fontsize=8)
    save(fig, out / "psnr_vs_views.png")
    for name, ds in evals.items():
        target = ds["test"].target(ds.background)
        fig, axs = plt.subplots(len(cfg.ks), 1, figsize=(1.0 + 0.28 * target.shape[0], 1.9 * len(cfg.ks)),
                                squeeze=False)
        gap = np.ones((6, target.shape[0] * 4, 3), np.float32)
        for ax, k in zip(axs[:, 0], cfg.ks):
            imgs = [target] + [renders.get((name, k, m), np.full_like(target, 0.5)) for m in methods]
            ax.imshow(np.concatenate(sum(([views_strip(np.clip(i, 0, 1)), gap] for i in imgs), [])[:-1], 0),
                      aspect="auto", interpolation="nearest")
            ax.set_yticks([(target.shape[1] + 6) * j + target.shape[1] / 2 for j in range(len(imgs))],
                          ["ground truth"] + methods, fontsize=7)
            ax.set_xticks([])
            ax.set_title(f"{name}, k = {k} input views", fontsize=9)
        save(fig, out / f"strips_{name}.png")
        fig, axs = plt.subplots(len(cfg.ks), len(methods), figsize=(2.6 * len(methods), 2.5 * len(cfg.ks)),
                                squeeze=False)
        for i, k in enumerate(cfg.ks):
            for j, m in enumerate(methods):
                density_panel(axs[i, j], densities[(name, k, m)], ds.bound, ds.meta.get("polygon"),
                              m if i == 0 else "", res=96)
                if j == 0:
                    axs[i, j].set_ylabel(f"k = {k}")
        save(fig, out / f"density_{name}.png", dpi=90)
    fig, ax = plt.subplots(figsize=(5.5, 3.4))
    for enc in dict.fromkeys(r["encoder"] for r in history):
        t, loss = np.array([(r["time"], r["loss"]) for r in history if r["encoder"] == enc], float).T
        w = min(10, len(loss))
        if w:
            ax.semilogy(t[w - 1:], np.convolve(loss, np.ones(w) / w, mode="valid"), label=f"{enc} encoder")
    ax.set(xlabel="training time [s]", ylabel="MSE (running mean)")
    ax.grid(alpha=0.3)
    ax.legend()
    save(fig, out / "training.png")
    ev = {(s["scene"], s["method"], s["k"]): s for s in summary if s["group"] == "eval"}
    table = [{"scene": n, "method": m, **{f"k={k}": mean_std(ev[(n, m, k)], "psnr") for k in cfg.ks}}
             for n in cfg.eval_scenes for m in methods]
    diff, verdict = [], []
    for n in cfg.eval_scenes:
        ahead = set()
        for m in methods[:-1]:
            line = {"scene": n, "pixelNeRF - NeRF": m}
            for k in cfg.ks:
                d = ev[(n, m, k)]["psnr"] - ev[(n, "NeRF", k)]["psnr"]
                line[f"k={k}"] = f"{d:+.2f}" if np.isfinite(d) else "NeRF failed"
                if not np.isfinite(d) or d > 0:
                    ahead.add(k)
            diff.append(line)
        verdict.append(f"* {n}: a pixelNeRF variant is ahead of NeRF with k = "
                       f"{', '.join(str(k) for k in cfg.ks if k in ahead) or 'none'}; NeRF is level or ahead with "
                       f"k = {', '.join(str(k) for k in cfg.ks if k not in ahead) or 'none'}.")
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
         + markdown_table(table) + "\nDifference of the means to NeRF [dB]:\n\n" + markdown_table(diff) + "\n"
         + "\n".join(verdict) + "\n\n![PSNR vs views](psnr_vs_views.png)"),
        ("Generalisation", "pixelNeRF on held-out views of training outlines and on unseen outlines:\n\n"
         + markdown_table(gen)),
        ("Test views", "\n".join(f"![{n}](strips_{n}.png)\n\n![density {n}](density_{n}.png)\n"
                                 for n in cfg.eval_scenes) + "\n![training loss](training.png)"),
    ])
