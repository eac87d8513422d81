"""The gradients' scatter-adds into a copy per thread (``ReduceMode.Expand``, up to
:data:`mitnerf.train.backend_drjit.EXPAND_BYTES`) against Dr.Jit's atomic adds, on the lego's training steps, in steps
a second and peak memory.

Each measurement is its own process (``benchmarks/adam_step.py``'s: the lego at 400 x 400, the default recipe sized
for an hour, the whole lattice from step 2, steps 20 to 120 timed, then the process's peak resident memory) with
Adam's one launch, the engine's choice for this lattice (:data:`~mitnerf.train.backend_drjit.LEAN_ADAM_ABOVE`); the
order alternates over ``--repeats``. ``copies``: the engine's own threshold; ``atomic``: ``EXPAND_BYTES = 0``
(Dr.Jit's threshold, under which the lattice's arrays do not fall).

Records ``scatter/lego`` in ``results.json``. Where the data is absent, one line says so and nothing runs.

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


def main(argv=None) -> int:
    args = lego_step_args("scatter", __doc__, argv, DATA, 2)
    if args is None:
        return 0
    runs = alternating(tuple(MODES), args.repeats, lambda mode: measure(args.data, "fused", {}, MODES[mode]))
    v = medians(runs, ("steps_per_s", "peak_gib"))
    v.update(params=runs["copies"][0]["params"], step_ratio=v["copies_steps_per_s"] / v["atomic_steps_per_s"],
             peak_added_gib=v["copies_peak_gib"] - v["atomic_peak_gib"], repeats=args.repeats)
    line = (f"lego 400, whole lattice ({v['params'] / 1e6:.1f} M parameters), training steps: gradients in a copy per "
            f"thread {v['copies_steps_per_s']:.2f} steps/s, peak {v['copies_peak_gib']:.2f} GiB; atomic adds "
            f"{v['atomic_steps_per_s']:.2f} steps/s, peak {v['atomic_peak_gib']:.2f} GiB (copies "
            f"{v['step_ratio']:.2f}x the steps for {v['peak_added_gib']:+.2f} GiB)")
    print(line, flush=True)
    record_result("scatter/lego", v, line, COMMAND, threads=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
