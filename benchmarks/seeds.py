"""Stability of every recipe, measured: 100 seeded short fits per field family on the bunny.

Each 2D recipe (``grid-2d``, ``hashlinear-2d``, ``hashgrid-2d``, ``vanilla-2d``) is trained ``--seeds`` times
(seed = initial weights, batches, jitter) for a short fixed number of steps on the
NeRF2D-protocol bunny (50 noisy views of 100 px); every run is classified by
:func:`mitnerf.train.evaluate.classify` (``nan``, ``collapsed`` or ``ok``) and its test
PSNR kept. Prints a table and records it in ``results.json`` (``seeds/<recipe>``).

    python benchmarks/seeds.py [--seeds 100] [--families grid hashlinear hashgrid vanilla]
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from tqdm.auto import tqdm

from _common import bunny
from mitnerf.train.fit import fit_and_evaluate
from mitnerf.train.recipes import recipe_for
from mitnerf.results import record_result

STEPS = {"grid": 300, "hashlinear": 300, "hashgrid": 300, "vanilla": 300}
"""Steps of each short fit (a few seconds each)."""


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=100)
    p.add_argument("--families", nargs="+", default=list(STEPS))
    args = p.parse_args(argv)
    ds = bunny()
    print(f"{'recipe':<12} {'runs':>4} {'nan':>4} {'collapsed':>9} {'median':>7} {'p10':>6} {'p90':>6} "
          f"{'min':>6} {'max':>6} {'s/run':>6}")
    for family in args.families:
        recipe = recipe_for(family, 2)
        status, psnrs = [], []
        t0 = time.perf_counter()
        for seed in tqdm(range(args.seeds), desc=recipe.name, leave=False):
            r = recipe.at_steps(STEPS[family], seed=seed, val_every=0, progress=False)
            _, rec = fit_and_evaluate(ds, r, geometry_metrics=False)
            status.append(rec.status)
            if rec.status == "ok":
                psnrs.append(rec.psnr)
        per_run = (time.perf_counter() - t0) / args.seeds
        p = np.array(psnrs) if psnrs else np.array([np.nan])
        v = dict(runs=args.seeds, nan=status.count("nan"), collapsed=status.count("collapsed"), steps=STEPS[family],
                 median=float(np.median(p)), p10=float(np.percentile(p, 10)), p90=float(np.percentile(p, 90)),
                 min=float(p.min()), max=float(p.max()), seconds_per_run=per_run)
        print(f"{recipe.name:<12} {v['runs']:>4} {v['nan']:>4} {v['collapsed']:>9} {v['median']:>7.2f} "
              f"{v['p10']:>6.2f} {v['p90']:>6.2f} {v['min']:>6.2f} {v['max']:>6.2f} {per_run:>6.1f}", flush=True)
        record_result(f"seeds/{recipe.name}", v,
                      f"{v['runs']} seeds x {STEPS[family]} steps: {v['nan']} NaN, {v['collapsed']} collapsed; test "
                      f"PSNR median {v['median']:.2f} dB (10-90 %: {v['p10']:.2f}-{v['p90']:.2f}, min {v['min']:.2f})",
                      f"python benchmarks/seeds.py --seeds {args.seeds} --families {family}", recipe=recipe.name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
