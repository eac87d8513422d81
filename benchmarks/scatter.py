"""The gradients' scatter-adds into a copy per thread (``ReduceMode.Expand``, up to
:data:`mitnerf.train.backend_drjit.EXPAND_BYTES`) against Dr.Jit's atomic adds, on the lego's training steps, in steps
a second and peak memory.

Each measurement is its own process (``benchmarks/adam_step.py``'s: the lego at 400 x 400, then the process's peak
resident memory) with Adam's one launch; the order alternates over the repeats. ``copies``: the engine's own
threshold; ``atomic``: ``EXPAND_BYTES = 0`` (Dr.Jit's threshold). Cases (``CASES``):

- ``lego``: the default recipe sized for an hour, the whole lattice from step 2 (21.7 M density and 32.9 M colour
  floats, over Dr.Jit's threshold), steps 20 to 120 timed, ``--repeats`` rounds;
- ``lego_hashgrid``: the ``hashgrid-3d`` recipe (its table, 1.27 M floats, just over Dr.Jit's threshold),
  steps 100 to 500 timed (after the occupancy grid's warm-up), twice the rounds: its step rate varies more
  between processes.

Records ``scatter/lego`` and ``scatter/lego_hashgrid`` in ``results.json``. Where the data is absent, one line says so
and nothing runs.

    python benchmarks/scatter.py [--data ../shared/data/nerf_synthetic/lego_400] [--repeats 2]
"""

from __future__ import annotations

import sys

from mitnerf.results import record_result

if __package__:                        # imported as benchmarks.scatter (the tests)
    from ._cli import alternating, lego_step_args, medians
    from .adam_step import measure
    from .lego import DATA
else:                                  # run as python benchmarks/scatter.py
    from _cli import alternating, lego_step_args, medians
    from adam_step import measure
    from lego import DATA

COMMAND = "python benchmarks/scatter.py"
MODES = {"copies": None, "atomic": 0}
"""``EXPAND_BYTES`` per mode (None: the engine's own)."""
CASES = {"lego": ("whole lattice", {}, 1),
         "lego_hashgrid": ("hashgrid-3d", {"recipe": "hashgrid-3d", "timed": [100, 500]}, 2)}
"""``{record under scatter/: (what it trains, adam_step.measure's settings, rounds per --repeats)}``."""


def main(argv=None) -> int:
    args = lego_step_args("scatter", __doc__, argv, DATA, 2)
    if args is None:
        return 0
    for case, (what, settings, rounds) in CASES.items():
        runs = alternating(tuple(MODES), rounds * args.repeats,
                           lambda mode: measure(args.data, "fused", settings, MODES[mode]))
        v = medians(runs, ("steps_per_s", "peak_gib"))
        v.update(params=runs["copies"][0]["params"], step_ratio=v["copies_steps_per_s"] / v["atomic_steps_per_s"],
                 peak_added_gib=v["copies_peak_gib"] - v["atomic_peak_gib"], repeats=rounds * args.repeats)
        line = (f"lego 400, {what} ({v['params'] / 1e6:.1f} M parameters), training steps: gradients in a copy per "
                f"thread {v['copies_steps_per_s']:.2f} steps/s, peak {v['copies_peak_gib']:.2f} GiB; atomic adds "
                f"{v['atomic_steps_per_s']:.2f} steps/s, peak {v['atomic_peak_gib']:.2f} GiB (copies "
                f"{v['step_ratio']:.2f}x the steps for {v['peak_added_gib']:+.2f} GiB; medians of {v['repeats']})")
        print(line, flush=True)
        record_result(f"scatter/{case}", v, line, COMMAND, threads=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
