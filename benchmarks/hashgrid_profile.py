"""Where the hash grid's time goes on a CPU, against the dense grid, on the 2D bunny.

One run, 2 threads, the ``hashgrid-2d``, ``hashlinear-2d`` (a hash grid decoded linearly, no network) and
``grid-2d`` recipes (1024 rays per step):

* the training step of each, median over rounds (steps alternate between contenders); these are early step
  numbers, before the grid upsamples and before the linearly decoded grid's finest level joins;
* the hash grid's step split: the encoding alone (forward and backward of
  :func:`mitnerf.fields.hashenc.hash_encode` on as many points as a step evaluates, table
  gradient by scatter-add), the step with the occupancy grid switched the other way from
  the recipe, and the step at 24, 48 and 96 samples per ray;
* test PSNR after each recipe's 10 s for the hash grid at three table sizes, and for the linearly decoded one,
  against the grid, with parameter counts (the grid's at its final resolution); every recipe first trains
  untimed past its last schedule change (``_common.warm_kernels``), so its 10 s buy steps, not compilation;
* generalisation: training-view and test PSNR of each recipe after equal step counts
  (``--steps``): a hash grid whose training PSNR climbs while its test PSNR stays is limited by
  what it learns from the views, not by the steps a budget buys.

Prints the figures and records them in ``results.json`` (``hashgrid/...``).

    python benchmarks/hashgrid_profile.py [--rounds 20] [--steps 300 1000 3000]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import drjit as dr
import numpy as np
from drjit.auto.ad import Float

from _common import alternate, backend, bunny, warm_kernels
from mitnerf.fields import make_field
from mitnerf.fields.hashenc import hash_encode
from mitnerf.results import record_result
from mitnerf.train.fit import fit_and_evaluate
from mitnerf.train.recipes import get_recipe

COMMAND = "python benchmarks/hashgrid_profile.py"


def encoding_time(field, n: int, rounds: int) -> float:
    """Seconds of the encoding's forward and backward on ``n`` points (median)."""
    rng = np.random.default_rng(0)
    table = Float(rng.uniform(-1e-4, 1e-4, field.n_table).astype(np.float32))
    x = [Float(rng.random(n).astype(np.float32)) for _ in range(field.dim)]
    cot = [Float(rng.normal(size=n).astype(np.float32)) for _ in range(field.layout.n_levels * field.layout.features)]
    ts = []
    for _ in range(rounds + 2):
        t = dr.detach(table)
        dr.enable_grad(t)
        t0 = time.perf_counter()
        feats = hash_encode(t, x, field.layout)
        dr.backward(sum(dr.sum(f * c) for f, c in zip(feats, cot)))
        dr.eval(dr.grad(t))
        dr.sync_thread()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts[2:])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rounds", type=int, default=20)
    p.add_argument("--steps", type=int, nargs="+", default=[300, 1000, 3000])
    args = p.parse_args(argv)
    dr.set_thread_count(2)
    ds = bunny()
    hg, grid, lin = get_recipe("hashgrid-2d"), get_recipe("grid-2d"), get_recipe("hashlinear-2d")
    contenders = {"hashgrid": backend("drjit", hg.model, ds), "grid": backend("drjit", grid.model, ds),
                  "hashlinear": backend("drjit", lin.model, ds)}
    for n in (24, 96):
        contenders[f"hashgrid {n} samples"] = backend("drjit", hg.override(n_coarse=n).model, ds)
    flipped = hg.copy()                 # the recipe's occupancy grid switched the other way
    occ = flipped.model.render.occupancy
    occ.enabled = not occ.enabled
    other = "hashgrid, " + ("with" if occ.enabled else "no") + " occupancy grid"
    contenders[other] = backend("drjit", flipped.model, ds)
    steps = alternate(contenders, args.rounds)
    field = make_field("hashgrid", **{**hg.model.field_args, "dim": 2})
    n_points = 1024 * hg.model.render.n_coarse
    enc = encoding_time(field, n_points, args.rounds)
    for name, t in steps.items():
        print(f"step {name:<30} {1000 * t:7.2f} ms")
    print(f"hash encoding fwd+bwd on {n_points:,} points (every sample, no occupancy skipping): {1000 * enc:.2f} ms")
    record_result("hashgrid/step", {**{k: 1000 * v for k, v in steps.items()}, "encoding_ms": 1000 * enc},
                  f"step: hash grid {1000 * steps['hashgrid']:.1f} ms, linearly decoded "
                  f"{1000 * steps['hashlinear']:.1f} ms, grid {1000 * steps['grid']:.1f} ms; the "
                  f"encoding alone {1000 * enc:.1f} ms on {n_points:,} points; {other.split(', ')[1]} "
                  f"{1000 * steps[other]:.1f} ms", COMMAND)
    rows = {}
    grid_rec = timed_fit(ds, grid.override(progress=False))
    for log2 in (10, 12, 14):
        rec = timed_fit(ds, hg.override(log2_hashmap_size=log2, progress=False))
        rows[log2] = (rec.psnr, rec.params)
        print(f"hash grid 2^{log2} entries per level: {rec.psnr:.2f} dB with {rec.params:,} parameters "
              f"({rec.params / grid_rec.params:.2f} of the grid's); grid {grid_rec.psnr:.2f} dB", flush=True)
    lin_rec = timed_fit(ds, lin.override(progress=False))
    ratio = lin_rec.params / grid_rec.params
    print(f"hash grid decoded linearly: {lin_rec.psnr:.2f} dB with {lin_rec.params:,} parameters ({ratio:.2f} of the "
          f"grid's); grid {grid_rec.psnr:.2f} dB", flush=True)
    best = max(rows, key=lambda k: rows[k][0])
    record_result("hashgrid/psnr", {"grid": grid_rec.psnr, "grid_params": grid_rec.params,
                                    **{f"2^{k}": v[0] for k, v in rows.items()},
                                    "hashlinear": lin_rec.psnr, "hashlinear_params": lin_rec.params},
                  f"10 s on the bunny: grid {grid_rec.psnr:.2f} dB ({grid_rec.params:,} parameters); hash grid best "
                  f"2^{best} {rows[best][0]:.2f} dB ({rows[best][1] / grid_rec.params:.2f} of the parameters), "
                  f"gap {grid_rec.psnr - rows[best][0]:.2f} dB; hash grid decoded linearly {lin_rec.psnr:.2f} dB "
                  f"({ratio:.2f} of the parameters), gap {grid_rec.psnr - lin_rec.psnr:.2f} dB", COMMAND)
    gen = generalisation(ds, {"hashgrid": hg, "hashlinear": lin, "grid": grid}, args.steps)
    record_result("hashgrid/generalisation", gen,
                  "train / test PSNR after equal steps: " + "; ".join(
                      f"{name} " + ", ".join(f"{k} steps {v['train']:.1f} / {v['test']:.1f}" for k, v in runs.items())
                      for name, runs in gen.items()) + " dB", COMMAND)
    return 0


def timed_fit(ds, recipe):
    """The record of ``recipe``'s timed fit, its kernels compiled beforehand."""
    warm_kernels(ds, recipe)
    return fit_and_evaluate(ds, recipe, geometry_metrics=False)[1]


def generalisation(ds, recipes: dict, steps: list) -> dict:
    """``{name: {steps: {"train": PSNR, "test": PSNR}}}``: each recipe trained for each step count (no clock)."""
    out = {}
    for name, recipe in recipes.items():
        out[name] = {}
        for n in steps:
            run, rec = fit_and_evaluate(ds, recipe.at_steps(n, progress=False), geometry_metrics=False)
            train = run.record(ds, "train", geometry_metrics=False).psnr
            out[name][str(n)] = {"train": train, "test": rec.psnr}
            print(f"{name} {n} steps: train PSNR {train:.2f} dB, test {rec.psnr:.2f} dB", flush=True)
    return out


if __name__ == "__main__":
    sys.exit(main())
