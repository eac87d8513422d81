"""Adam's step on the lego's grid: ``drjit.opt.Adam``'s one launch against :class:`~mitnerf.train.adam.LeanAdam`
(one array at a time), in steps a second and peak memory.

Each measurement is its own process: it loads the lego (400 x 400), sizes the default recipe for an hour's budget,
goes to the whole lattice at once (``upsample_at`` 1 and 2) and times steps 20 to 120, then reads the process's
peak resident memory. Cases: the default lattice, and the finer one of ``benchmarks/lego.py`` part ``fine``
(``VARIANTS['fine']``); each with Adam's launch and with the lean step, the order alternating
over ``--repeats``. What it measures is the rule :data:`mitnerf.train.backend_drjit.LEAN_ADAM_ABOVE` draws: above
it, two copies of the parameters less at the step's peak are worth the step time the lean step costs.

Records ``adam_step/lego`` in ``results.json``. Where the data is absent, one line says so and nothing runs.

    python benchmarks/adam_step.py [--data ../shared/data/nerf_synthetic/lego_400] [--repeats 1]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from mitnerf.results import record_result

if __package__:                        # imported as benchmarks.adam_step (benchmarks/records.py under the tests)
    from ._cli import alternating, child, lego_step_args, medians
    from .lego import DATA, VARIANTS
else:                                  # run as python benchmarks/adam_step.py
    from _cli import alternating, child, lego_step_args, medians
    from lego import DATA, VARIANTS

COMMAND = "python benchmarks/adam_step.py"
CASES = {"default": {}, "fine": {k: json.loads(v) for k, v in (s.split("=", 1) for s in VARIANTS["fine"][2])}}
"""The lattices measured: the recipe's own, and part ``fine``'s of ``benchmarks/lego.py`` (its settings; the
render's samples do not touch a training step)."""

CHILD = r"""
import json, sys, time
import drjit as dr
from mitnerf.data.formats import load_dataset
from mitnerf.train import backend_drjit
from mitnerf.train.evaluate import peak_memory
from mitnerf.train.fit import fit
from mitnerf.train.recipes import get_recipe

data, lean, settings = sys.argv[1], sys.argv[2] == "lean", json.loads(sys.argv[3])
name, (first, last) = settings.pop("recipe", "grid-3d"), settings.pop("timed", (20, 120))
backend_drjit.LEAN_ADAM_ABOVE = 0 if lean else 1 << 62
if len(sys.argv) > 4:
    backend_drjit.EXPAND_BYTES = int(sys.argv[4])
clock, n_params = {}, []
step = backend_drjit.DrJitBackend.step

def timed(self, index, seed, lr):
    if index in (first, last):
        dr.sync_thread()
        clock[index] = time.perf_counter()
        n_params.append(self.n_params())
    return step(self, index, seed, lr)

backend_drjit.DrJitBackend.step = timed
lattice = {"upsample_at": (1, 2)} if name == "grid-3d" else {}
recipe = get_recipe(name).override(time_budget=3600.0, iters=last + 1, val_every=0, progress=False, **lattice,
                                   **settings)
fit(load_dataset(data), recipe)
rate = (last - first) / (clock[last] - clock[first])
print(json.dumps({"steps_per_s": rate, "params": n_params[-1], "peak_gib": peak_memory()}))
"""


def measure(data: Path, adam: str, settings: dict, expand_bytes: int | None = None) -> dict:
    """Steps a second between the timed steps (by default steps 20 to 120 on ``grid-3d``'s whole lattice), the
    parameters and the peak memory, in a fresh process:
    Adam's launch (``adam="fused"``) or the lean step; ``settings``: the recipe's overrides, and optionally
    ``recipe`` (another recipe than ``grid-3d``, trained from its own start) and ``timed`` (the first and last step
    timed); ``expand_bytes``: the engine's :data:`~mitnerf.train.backend_drjit.EXPAND_BYTES` (None: its own)."""
    return child(CHILD, data, adam, json.dumps(settings), *(() if expand_bytes is None else (expand_bytes,)))


def main(argv=None) -> int:
    args = lego_step_args("adam_step", __doc__, argv, DATA, 1)
    if args is None:
        return 0
    values, lines = {}, []
    for case, settings in CASES.items():
        runs = alternating(("fused", "lean"), args.repeats, lambda adam: measure(args.data, adam, settings))
        v = medians(runs, ("steps_per_s", "peak_gib"))
        v.update(params=runs["lean"][0]["params"], step_ratio=v["lean_steps_per_s"] / v["fused_steps_per_s"],
                 peak_saved_gib=v["fused_peak_gib"] - v["lean_peak_gib"], settings=settings)
        values[case] = v
        lines.append(f"{case} lattice ({v['params'] / 1e6:.1f} M parameters): Adam's launch "
                     f"{v['fused_steps_per_s']:.2f} steps/s, peak {v['fused_peak_gib']:.2f} GiB; lean "
                     f"{v['lean_steps_per_s']:.2f} steps/s ({v['step_ratio']:.2f}x), peak {v['lean_peak_gib']:.2f} GiB")
        print(lines[-1], flush=True)
    values["repeats"] = args.repeats
    record_result("adam_step/lego", values, "lego 400, whole lattice: " + "; ".join(lines), COMMAND, threads=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
