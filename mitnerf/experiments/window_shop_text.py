"""The prose of the window-shopping report (:mod:`.window_shop`): set-up, results, the
comparison with the original report's claims, and the caveats, built from the rows."""

from __future__ import annotations

import math

from .window_shop_report import (REPORT_COLLAPSE, collapse_summary, factor_effects, num, pivot_factors,
                                 pivot_views, trend_collapse, trend_views)


def setup_text(rows: list[dict], cfg, wall: float, load: tuple | None = None) -> str:
    import os

    n_nerf = sum(r["field"] == "vanilla" for r in rows)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    cpu_text = (f"{cores} CPU cores; 1-minute load average {load[0]:.1f}-{load[1]:.1f} between runs (above "
                f"{cores} means other jobs shared the cores: timings are then pessimistic)." if load else
                f"{cores} CPU cores.")
    design = ("the whole factorial (views x L x N_c x view dependence x hierarchical)" if cfg.full else
              f"one factor at a time around the base (L = 10, N_c = 64, view dependence on, hierarchical on), "
              f"each of {', '.join(cfg.factors)} changed alone at {', '.join(map(str, cfg.ofat_views))} views, "
              f"plus the base at every number of views")
    compile_note = ("A 3-step throw-away run compiles each model's kernels first, so train time counts tracing "
                    "but not compiling (except the dense grid's kernels for its upsampled resolutions, compiled "
                    "when it reaches them)." if cfg.compile_first else "Train time includes compiling the kernels.")
    text = f"""
- Objects: {', '.join(cfg.objects)} (unit sphere, white background). Training photos: the first N of
  {max(cfg.pool_views, max(cfg.views))} random, slightly noisy views on the upper hemisphere (so fewer views are a
  subset of more), N in {{{', '.join(map(str, cfg.views))}}}; test: {cfg.test_views} noise-free views on the
  360 degree orbit at 25 degrees. Images {cfg.resolution}x{cfg.resolution}.
- NeRF (`field='vanilla'`): {cfg.width} x {cfg.depth} ReLU trunk (the original: 256 x 8; scaled down for 2 CPU
  cores), softplus density (ours; the original NeRF uses ReLU), direction encoding L = {cfg.dir_L},
  {cfg.batch_rays} rays per step, Adam {cfg.lr:g} -> {cfg.lr_final:g}. Hierarchical: N_f = N_c x {cfg.fine_ratio:g}
  importance samples with a separate fine field.
- Design: {design}. Grid (our fast model, its 3D preset, which
  upsamples 33^3 -> 65^3 -> 129^3 at steps 200 and 600: the fixed-iteration runs stay at 33^3) at every number of
  views: {'yes' if cfg.grid else 'no'}.
  ReLU-density probes (the original NeRF's activation): N_c in {{{', '.join(map(str, cfg.probe_n_coarse))}}} at
  {', '.join(map(str, cfg.probe_views)) or 'no'} views.
- Budgets: fixed iterations = {cfg.iters} steps; fixed time = {cfg.time_budget:g} s of training (the learning-rate
  schedule follows the clock); NeRF learning-rate warm-up {cfg.warmup} steps. {compile_note}
- {len(rows)} trainings ({n_nerf} NeRF) in {wall / 60:.1f} min wall time, seed {cfg.seed}, {cpu_text}
- Times depend on how busy the machine is: steps per second, and so PSNR at a fixed time, vary from run to
  run (up to ~2x between an idle and a busy 2-core machine); PSNR at a fixed number of steps does not.
"""
    for k, v in cfg.extras.items():
        text += f"- {k}: {v}\n"
    return text


def comparison_text(rows: list[dict], fewest: int) -> str:
    collapsed, n_nc, relu_collapsed = collapse_summary(rows)
    relu = [r for r in rows if r["field"] == "vanilla" and r["activation"] != "softplus"]
    empties = sorted({round(num(r["psnr_empty"]), 2) for r in rows if math.isfinite(num(r.get("psnr_empty")))})
    lo, hi = REPORT_COLLAPSE
    text = f"""
**Claim 1: "PSNR stays around 23-25 dB even at 5 views".**

{trend_views(rows)}
Read with the budgets in mind: our NeRF runs are short (see the set-up), so their absolute PSNR is that of
an undertrained model; the change from many to few views is the comparable quantity. The grid shows
what the same photos allow a fast model in the same time.

**Claim 2: "N_c = 128 with 5 views collapsed to 15-16 dB".**

{trend_collapse(rows)}
Summary: {collapsed} of {n_nc} softplus NeRF runs with N_c = 128 at {fewest} views collapsed; {relu_collapsed} of
{len(relu)} ReLU-density probes collapsed. A field collapsed to empty space renders only background and
scores exactly the empty-render PSNR: {', '.join(f'{e:.2f}' for e in empties)} dB on our test views. If the
report's collapsed runs were empty too, {lo:g}-{hi:g} dB was that level on its images (which had other objects,
views and backgrounds); we cannot check this without them.
"""
    down = sorted({int(r["n_coarse"]) for r in relu if r["status"] != "ok"})
    up = sorted({int(r["n_coarse"]) for r in relu if r["status"] == "ok"})
    if down:
        which = ("only at N_c = 128, as in the report" if down == [128] else
                 f"at N_c = {', '.join(map(str, down))}" + (f" (not at {', '.join(map(str, up))})" if up else ""))
        text += f"""
Why ours differs: with the original NeRF's ReLU density our NeRF collapses too, {which}. The evidence
is in the rows above: opacity on the object ~0, every test view pure background, and a maximum density of
exactly 0 on a 24^3 grid over the object's cube. A ReLU density that is 0 everywhere has a zero gradient
everywhere (ReLU'(x) = 0 for x < 0), so nothing can bring it back: the collapse is permanent once the
density head's pre-activations are negative at every sample. Our default softplus density (mip-NeRF's
choice) has a positive gradient everywhere and starts slightly transparent, so the same configurations keep
learning. Whether a ReLU run dies depends on its random start and the first steps (one seed per
configuration here and, as far as we know, in the report), so a collapse at one N_c and not the other is
not evidence about N_c itself.
"""
    elif relu:
        text += """
Why ours differs: not even the ReLU-density probes collapsed at our sizes and seed, so the report's collapse
is not reproduced; whether a ReLU density dies depends on the random start and on the model size.
"""
    return text


def report_sections(rows: list[dict], cfg, wall: float, table: str, thumbs: bool, fewest: int,
                    load: tuple | None = None) -> list:
    ofat = pivot_factors(rows, fewest)
    sections = [
        ("Question", "A seller posts a few photos of a product; a buyer wants to turn it around. How many photos "
                     "does a NeRF need, and which of its hyperparameters matter? This repeats the original "
                     "window-shopping report's ablation (views x positional encoding L x N_c x view dependence x "
                     "hierarchical sampling) at a fixed iteration budget and at a fixed time budget, and compares "
                     "with its two headline findings."),
        ("Set-up", setup_text(rows, cfg, wall, load)),
        ("PSNR against views", "![test PSNR against training photos](psnr_vs_views.png)\n\n" + pivot_views(rows)),
        (f"One factor at a time ({fewest} views)", "Test PSNR (difference to the base in brackets).\n\n" + ofat
         + "\nMean change, best first:\n\n" + factor_effects(rows, fewest)),
        ("PSNR against train time", "Circles: fixed iterations; squares: fixed time. Blue: NeRF base by "
                                    "views; black: grid; colours: one factor changed; red: ReLU probes; red "
                                    "outline: collapsed.\n\n![test PSNR against train time](psnr_vs_time.png)"),
        ("Comparison with the report", comparison_text(rows, fewest)),
    ]
    if thumbs:
        sections.append(("Renders and opacity", f"![first test view of each run at {fewest} views, and its "
                                                f"opacity](thumbnails.png)"))
    sections.append(("All runs", "`results.csv` has every column (also SSIM, depth error, opacity off the object, "
                                 "density statistics on a 24^3 grid over the unit cube).\n\n" + table))
    return sections
