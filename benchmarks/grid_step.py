"""The dense grid's colour skipping, measured: the same fit with and without it, at equal steps.

The integral leaves out the colour of samples whose weight is at most ``min_color_weight`` (empty space, the
inside of a surface), and the dense grid then reads only their density (:mod:`mitnerf.render.integral`). Each
pair of fits trains the default recipe for ``--steps`` steps (no time budget, same seed) with the recipe's
``min_color_weight`` and with 0 (the colour of every sample of positive weight read), alternating the order
over ``--repeats`` pairs, and reports both training times, their ratio and both test PSNRs (and IoU or Chamfer
distance): on the 2D bunny and, unless ``--no-3d``, on the glossy vase (25 views of 100 x 100).

Prints the figures and records them in ``results.json`` (``grid_step/2d``, ``grid_step/3d``).

    python benchmarks/grid_step.py [--steps 400] [--steps-3d 600] [--repeats 2] [--no-3d]
"""

from __future__ import annotations

import argparse
import statistics
import sys

from _common import bunny
from fit_table import dataset
from mitnerf.results import record_result
from mitnerf.train.fit import fit_and_evaluate
from mitnerf.train.recipes import recipe_for

COMMAND = "python benchmarks/grid_step.py"


def fit(ds, recipe, steps: int, w_min: float):
    _, rec = fit_and_evaluate(ds, recipe.at_steps(steps, min_color_weight=w_min, progress=False))
    return rec


def pair(ds, dim: int, steps: int, repeats: int) -> dict:
    recipe = recipe_for("grid", dim)
    w_min = recipe.model.render.min_color_weight
    runs = {"skip": [], "every": []}
    for k in range(repeats):
        order = ("skip", "every") if k % 2 == 0 else ("every", "skip")
        for name in order:
            runs[name].append(fit(ds, recipe, steps, w_min if name == "skip" else 0.0))
    geo = "iou" if dim == 2 else "chamfer"
    out = {}
    for name, recs in runs.items():
        out[f"{name}_seconds"] = statistics.median(r.train_time for r in recs)
        out[f"{name}_psnr"] = statistics.median(r.psnr for r in recs)
        out[f"{name}_{geo}"] = statistics.median(getattr(r, geo) for r in recs)
    out["speedup"] = out["every_seconds"] / out["skip_seconds"]
    out.update(steps=steps, repeats=repeats, recipe=recipe.name, min_color_weight=w_min)
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=400)
    p.add_argument("--steps-3d", type=int, default=600)
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--no-3d", action="store_true")
    args = p.parse_args(argv)
    cases = [("2d", bunny(), 2, args.steps)]
    if not args.no_3d:
        cases.append(("3d", dataset("vase_glossy", 3), 3, args.steps_3d))
    for key, ds, dim, steps in cases:
        v = pair(ds, dim, steps, args.repeats)
        geo = "iou" if dim == 2 else "chamfer"
        summary = (f"{v['recipe']}, {steps} steps: {v['skip_seconds']:.1f} s with colour skipping, "
                   f"{v['every_seconds']:.1f} s reading every colour ({v['speedup']:.2f}x); test PSNR "
                   f"{v['skip_psnr']:.2f} vs {v['every_psnr']:.2f} dB, {geo} {v[f'skip_{geo}']:.4f} vs "
                   f"{v[f'every_{geo}']:.4f}")
        print(summary, flush=True)
        record_result(f"grid_step/{key}", v, summary, COMMAND, recipe=v["recipe"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
