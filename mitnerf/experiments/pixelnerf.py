"""Experiment ``pixelnerf``: a 2D pixelNeRF against NeRF with 1, 3, 5 and 9 input views.

**Question.** pixelNeRF (Yu et al. 2021) learns a prior across scenes, so with one to
three views it should beat a NeRF fitted to those views alone; with more views the
per-scene NeRF should catch up. Does that hold in 2D, on CPU-sized budgets?

**Protocol.**

* pixelNeRF (:mod:`mitnerf.fields.pixelnerf`) is trained on ``n_outlines`` procedural
  star-shaped outlines (:mod:`.pixelnerf_data`) plus ``extra_scenes`` (the square
  scenes), ``train_views`` random noisy views each; each step uses 1-9 random views of
  one scene as input and rays of its other views as targets. Two variants: a frozen
  random encoder (as NeRF2D) and a trained one, same budget each.
* **bunny** and **tu** are never trained on. Each is rendered with ``eval_train_views``
  random noisy views; for every ``k`` in ``ks`` the ``k`` views nearest an even spread
  (:func:`.pixelnerf_data.pick_views`) are pixelNeRF's input and the *whole* training set
  of a NeRF (``mitnerf.train.presets.preset(field, 2)``, ``nerf_iters`` steps). Both are
  scored on the same ``eval_test_views`` evenly spaced, noise-free test views.
* pixelNeRF alone is also scored on held-out views of ``n_seen`` training outlines and on
  ``n_unseen`` outlines it never saw (same ``k`` views rule).

Outputs: ``results.csv`` (one row per method, scene, k), ``training.csv`` (pixelNeRF
loss curves) and ``training.png`` (the curves drawn), ``psnr_vs_views.png``,
``strips_<scene>.png`` (test views of each method beside ground truth),
``density_<scene>.png`` and ``report.md``.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..fields.pixelnerf import PixelNeRFConfig
from .common import cached_dataset, markdown_table, write_csv, write_report
from .pixelnerf_data import outline_dataset, outline_rig, pick_views, scene_views
from .pixelnerf_train import PixelRun, PixelTrainConfig, context_of, density_grid, render_rays, train


@dataclass
class PixelNeRFExperimentConfig:
    """Sizes and budgets of the experiment (defaults: the full run, <= 15 min on 2 cores)."""

    n_outlines: int = 48
    """Procedural outlines pixelNeRF is trained on."""
    extra_scenes: tuple = ("square", "square_concave")
    """Named scenes added to the training set (never bunny or tu: they are the test)."""
    train_views: int = 24
    """Random noisy views per training scene."""
    outline_test_views: int = 8
    """Evenly spaced test views per outline (held-out views)."""
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
    encoders: tuple = ("frozen", "trained")
    """pixelNeRF variants."""
    model: PixelNeRFConfig = field(default_factory=PixelNeRFConfig)
    """pixelNeRF architecture (``encoder`` is set per variant)."""
    pixel: PixelTrainConfig = field(default_factory=lambda: PixelTrainConfig(iters=8000, time_budget=150.0))
    """pixelNeRF training, per variant: 8000 steps (~2 min unloaded), cut at 150 s on a busy
    machine. The loss drops sharply after ~2500 steps, when the field starts to use agreement
    between views; runs cut before that are far worse with many views."""
    field: str = "vanilla"
    """Field family of the NeRF baselines (``mitnerf.train.presets``)."""
    nerf_iters: int = 1000
    """Steps of each NeRF baseline (the preset's learning-rate schedule over these steps)."""
    nerf_batch_rays: int | None = 256
    """Rays per NeRF step; None keeps the preset's (1024, tuned for 50 views). With 9 views of
    bunny, 1000 x 256 rays reached 22.0 dB in 42 s where 300 x 1024 reached 20.5 dB."""
    nerf_time_budget: float | None = 60.0
    """Seconds of training per NeRF baseline at most (None: only ``nerf_iters``)."""
    progress: bool = True
    """Progress bars."""


def quick_config() -> PixelNeRFExperimentConfig:
    """``--quick``: the same comparison, much shorter (about 2 minutes)."""
    return PixelNeRFExperimentConfig(n_outlines=12, n_seen=2, n_unseen=2, eval_test_views=8,
                                     pixel=PixelTrainConfig(iters=4000, time_budget=22.0), nerf_iters=200,
                                     nerf_time_budget=4.0)


def tiny_config() -> PixelNeRFExperimentConfig:
    """Smallest run that still writes every file (the test suite)."""
    return PixelNeRFExperimentConfig(n_outlines=2, extra_scenes=(), train_views=6, outline_test_views=4, n_seen=1,
                                     n_unseen=1, eval_scenes=("bunny",), eval_train_views=8, eval_test_views=4,
                                     ks=(1, 3), model=PixelNeRFConfig(channels=8, dilations=(1, 2), width=32),
                                     pixel=PixelTrainConfig(iters=10, batch_rays=64, n_samples=24, k_range=(1, 3)),
                                     nerf_iters=8, nerf_time_budget=None, progress=False)


# ---------------------------------------------------------------------- data
def training_scenes(cfg: PixelNeRFExperimentConfig, seed: int):
    """(pixelNeRF's training views, the outlines' datasets for held-out scoring)."""
    from ..data.generate import make_dataset
    from ..scenes.registry import get_scene

    sets = [outline_dataset(1000 * seed + i, cfg.train_views, cfg.outline_test_views) for i in range(cfg.n_outlines)]
    names = [f"outline{1000 * seed + i}" for i in range(cfg.n_outlines)]
    for j, name in enumerate(cfg.extra_scenes):
        sets.append(make_dataset(get_scene(name), outline_rig(cfg.train_views, 0, 77 + j), progress=False))
        names.append(name)
    return [scene_views(ds, "train", n) for ds, n in zip(sets, names)], sets[:cfg.n_outlines]


def eval_dataset(cfg: PixelNeRFExperimentConfig, scene: str, seed: int):
    rig = dataclasses.replace(outline_rig(cfg.eval_train_views, cfg.eval_test_views, 100 + seed), n_val=2)
    return cached_dataset(scene, rig)


# ---------------------------------------------------------------------- scoring
def score(pred: dict, ds, split: str = "test") -> dict:
    from ..train.metrics import depth_error, psnr, ssim

    s = ds[split]
    target = s.target(ds.background)
    out = {"psnr": psnr(pred["rgb"], target), "ssim": ssim(pred["rgb"], target)}
    if s.depth is not None:
        out["depth_error"] = depth_error(pred["depth"], pred["opacity"], s.depth, s.mask)
    return out


def render_pixelnerf(run: PixelRun, ds, views: np.ndarray) -> dict:
    """Test views of ``ds`` rendered from its training views ``views``."""
    sv = scene_views(ds, "train")
    ctx = context_of(run.field, sv, views)
    test = ds["test"]
    o, d = test.cameras.rays()
    t0 = time.perf_counter()
    out = render_rays(run, ctx, o.reshape(-1, 2), d.reshape(-1, 2), ds.near, ds.far)
    shape = o.shape[:-1]
    return {"rgb": out["rgb"].reshape(*shape, 3), "depth": out["depth"].reshape(shape),
            "opacity": out["opacity"].reshape(shape), "time": (time.perf_counter() - t0) / max(len(test), 1)}


def fit_nerf(cfg: PixelNeRFExperimentConfig, ds, seed: int):
    from ..train.presets import preset
    from ..train.trainer import TrainingFailed, evaluate, fit

    mc, tc = preset(cfg.field, 2)
    tc.iters, tc.time_budget, tc.val_every, tc.seed, tc.progress = (cfg.nerf_iters, cfg.nerf_time_budget, 0, seed,
                                                                    cfg.progress)
    if cfg.nerf_batch_rays:
        tc.batch_rays = cfg.nerf_batch_rays
    try:
        run = fit(ds, mc, tc)
    except TrainingFailed as exc:
        return None, {"psnr": float("nan"), "note": str(exc)}
    ev = evaluate(run, ds, "test")
    return run, {"psnr": ev["psnr"], "ssim": ev["ssim"], "depth_error": ev.get("depth_error", float("nan")),
                 "train_time": run.train_time, "steps": run.steps, "renders": ev["renders"],
                 "render_time_per_view": ev["render_time_per_view"]}


# ---------------------------------------------------------------------- the experiment
def run(out: Path, quick: bool = False, seed: int = 0, config: PixelNeRFExperimentConfig | None = None) -> Path:
    """Run the experiment into ``out``; returns the path of ``report.md``."""
    from tqdm.auto import tqdm

    from ..viz.training import density_grid as nerf_density_grid
    from .pixelnerf_figures import plot_psnr, plot_training, save_densities, save_strips

    cfg = config or (quick_config() if quick else PixelNeRFExperimentConfig())
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    scenes, outlines = training_scenes(cfg, seed)
    unseen = [outline_dataset(1000 * seed + 500 + i, cfg.train_views, cfg.outline_test_views)
              for i in range(cfg.n_unseen)]
    evals = {name: eval_dataset(cfg, name, seed) for name in cfg.eval_scenes}
    picks = {name: {k: pick_views(ds["train"].cameras, k) for k in cfg.ks} for name, ds in evals.items()}
    rows, hist_rows, renders, densities = [], [], {}, {}
    bound = cfg.model.bound

    runs = {}
    for enc in cfg.encoders:
        mcfg = dataclasses.replace(cfg.model, encoder=enc)
        pcfg = dataclasses.replace(cfg.pixel, seed=seed, progress=cfg.progress)
        runs[enc] = r = train(mcfg, scenes, pcfg)
        hist_rows += [{"encoder": enc, "step": s, "time": t, "loss": l}
                      for s, t, l in zip(r.history["step"], r.history["time"], r.history["loss"])]
    jobs = [(name, ds, "eval") for name, ds in evals.items()]
    jobs += [(f"seen{i}", ds, "seen outline") for i, ds in enumerate(outlines[:cfg.n_seen])]
    jobs += [(f"unseen{i}", ds, "unseen outline") for i, ds in enumerate(unseen)]
    for enc, r in runs.items():
        for name, ds, group in tqdm(jobs, desc=f"score pixelNeRF ({enc})", disable=not cfg.progress, leave=False):
            for k in cfg.ks:
                views = picks[name][k] if name in picks else pick_views(ds["train"].cameras, k)
                pred = render_pixelnerf(r, ds, views)
                rows.append({"method": f"pixelNeRF ({enc})", "scene": name, "group": group, "k": k, **score(pred, ds),
                             "train_time": r.train_time, "steps": r.steps, "render_time_per_view": pred["time"]})
                if group == "eval":
                    renders[(name, k, f"pixelNeRF ({enc})")] = pred["rgb"]
                    ctx = context_of(r.field, scene_views(ds, "train"), views)
                    densities[(name, k, f"pixelNeRF ({enc})")] = density_grid(r, ctx, bound, 96)
    nerf_label = f"NeRF ({cfg.field})"
    for name, ds in evals.items():
        for k in cfg.ks:
            sub = ds.sparse(picks[name][k])
            nrun, m = fit_nerf(cfg, sub, seed)
            rows.append({"method": nerf_label, "scene": name, "group": "eval", "k": k,
                         **{key: v for key, v in m.items() if key != "renders"}})
            if nrun is not None:
                renders[(name, k, nerf_label)] = m["renders"]["rgb"]
                densities[(name, k, nerf_label)] = nerf_density_grid(nrun.backend, bound, 2, 96)
    total = time.perf_counter() - t_start

    write_csv(out / "results.csv", rows)
    write_csv(out / "training.csv", hist_rows)
    methods = [f"pixelNeRF ({e})" for e in cfg.encoders] + [nerf_label]
    plot_psnr(rows, methods, cfg.ks, out / "psnr_vs_views.png")
    plot_training(hist_rows, out / "training.png")
    for name, ds in evals.items():
        save_strips(ds["test"].target(ds.background), renders, name, cfg.ks, methods, out / f"strips_{name}.png")
        save_densities(densities, name, cfg.ks, methods, ds.meta.get("polygon"), bound, out / f"density_{name}.png")
    return _report(out, cfg, rows, methods, runs, total, seed, quick)


def _report(out: Path, cfg, rows, methods, runs, total, seed, quick) -> Path:
    ev = [r for r in rows if r["group"] == "eval"]
    table = []
    for name in cfg.eval_scenes:
        for m in methods:
            line = {"scene": name, "method": m}
            for k in cfg.ks:
                hit = [r for r in ev if r["scene"] == name and r["method"] == m and r["k"] == k]
                line[f"k={k}"] = f"{hit[0]['psnr']:.2f}" if hit else ""
            table.append(line)
    diff = []
    for name in cfg.eval_scenes:
        nerf = {r["k"]: r["psnr"] for r in ev if r["scene"] == name and r["method"] == methods[-1]}
        for m in methods[:-1]:
            line = {"scene": name, "pixelNeRF - NeRF": m}
            for k in cfg.ks:
                p = [r["psnr"] for r in ev if r["scene"] == name and r["method"] == m and r["k"] == k]
                if p and k in nerf:
                    line[f"k={k}"] = f"{p[0] - nerf[k]:+.2f}" if np.isfinite(nerf[k]) else "NeRF failed"
                else:
                    line[f"k={k}"] = ""
            diff.append(line)
    gen = []
    for m in methods[:len(cfg.encoders)]:
        for group in ("seen outline", "unseen outline"):
            line = {"method": m, "scenes": group}
            for k in cfg.ks:
                v = [r["psnr"] for r in rows if r["method"] == m and r["group"] == group and r["k"] == k]
                line[f"k={k}"] = f"{np.mean(v):.2f}" if v else ""
            gen.append(line)
    train_names = ", ".join(cfg.extra_scenes) or "none"
    budgets = (f"pixelNeRF: {cfg.pixel.iters} steps or {cfg.pixel.time_budget} s per variant, "
               f"{cfg.pixel.batch_rays} rays x {cfg.pixel.n_samples} samples per step, k drawn from "
               f"{cfg.pixel.k_range[0]}..{cfg.pixel.k_range[1]}; "
               + "; ".join(f"{e}: {r.steps} steps in {r.train_time:.0f} s" for e, r in runs.items())
               + f". NeRF ({cfg.field} preset, {cfg.nerf_batch_rays or 'preset'} rays per step): "
               + f"{cfg.nerf_iters} steps" + (f" or {cfg.nerf_time_budget} s" if cfg.nerf_time_budget else "")
               + " per fit.")
    nerf_note = ", ".join(f"{r['scene']} k={r['k']}: {r.get('steps', '?')} steps / "
                          f"{float(r.get('train_time', 0)):.0f} s" for r in ev if r["method"] == methods[-1])
    verdict = []
    for name in cfg.eval_scenes:
        cells = {k: [d[f"k={k}"] for d in diff if d["scene"] == name] for k in cfg.ks}
        ahead = [k for k in cfg.ks if any(c.startswith("+") and float(c) > 0 or c == "NeRF failed" for c in cells[k])]
        behind = [k for k in cfg.ks if k not in ahead]
        ks_text = lambda ks: ", ".join(map(str, ks)) or "none"
        verdict.append(f"* {name}: a pixelNeRF variant is ahead of NeRF with k = {ks_text(ahead)}; "
                       f"NeRF is level or ahead with k = {ks_text(behind)}.")
    sections = [
        ("Set-up", f"""{'Quick run (`--quick`): small budgets, read as a smoke test. ' if quick else ''}Seed {seed};
total wall time {total:.0f} s on {runs[next(iter(runs))].train_cfg.threads} threads.

* **Trained on:** {cfg.n_outlines} procedural star-shaped outlines
  (seeds {1000 * seed}..{1000 * seed + cfg.n_outlines - 1}, random lights) and {train_names};
  {cfg.train_views} random noisy views of 100 px each.
  **Never trained on:** {', '.join(cfg.eval_scenes)} and {cfg.n_unseen} further outlines.
* **Inputs:** for each k, the k of {cfg.eval_train_views} training views nearest an even spread; pixelNeRF
  reads them as its context, the NeRF baseline trains on exactly them.
* **Scored on:** {cfg.eval_test_views} evenly spaced, noise-free test views (PSNR over black).
* **Budgets:** {budgets}
* NeRF fits: {nerf_note}.
* pixelNeRF field: {cfg.model.channels} channels x {len(cfg.model.dilations)} dilated conv layers
  (dilations {cfg.model.dilations}) {'+ RGB ' if cfg.model.include_rgb else ''}-> {cfg.model.feature_size} features,
  linear lookup, {cfg.model.view_layers} per-view + {cfg.model.head_layers} head layers of {cfg.model.width}."""),
        ("PSNR against the number of input views",
         "Test PSNR [dB] on scenes pixelNeRF never saw:\n\n" + markdown_table(table)
         + "\nDifference to NeRF [dB] (positive: pixelNeRF ahead):\n\n" + markdown_table(diff)
         + "\n" + "\n".join(verdict) + "\n"
         + "\n![PSNR vs views](psnr_vs_views.png)\n"),
        ("Generalisation within the training distribution",
         "pixelNeRF on held-out views of training outlines and on unseen outlines (mean PSNR [dB]):\n\n"
         + markdown_table(gen)),
        ("Test views", "\n".join(f"![{n}](strips_{n}.png)\n\n![density {n}](density_{n}.png)\n"
                                 for n in cfg.eval_scenes)
         + "\nEach strip: test views side by side (one column per view); rows: ground truth, then each method. "
           "Density: log10(0.01 + sigma) with the true outline."),
        ("Training", "![pixelNeRF loss](training.png)\n\nAll numbers: `results.csv`; loss curves: `training.csv`."),
    ]
    return write_report(out, "pixelNeRF in 2D against NeRF with few views", sections)
