"""The dense grid's colour read in packets (``GridConfig.color_packets``) against float by float, on the lego's
training steps, in steps a second and peak memory.

Each measurement is its own process (``benchmarks/adam_step.py``'s: the lego at 400 x 400, the default recipe sized
for an hour, the whole lattice from step 2, steps 20 to 120 timed, then the process's peak resident memory), the
order alternating over ``--repeats``. Cases: the recipe's view harmonics of degree 1 (12 floats a vertex: three
packets of 4, no pad), and of degree 2 (``--set sh_degree=2``: 27 floats in records of 32, two packets of 16).

Records ``records/lego`` in ``results.json``. Where the data is absent, one line says so and nothing runs.

    python benchmarks/records.py [--data ../shared/data/nerf_synthetic/lego_400] [--repeats 2]
"""

from __future__ import annotations

import sys

from mitnerf.results import record_result

if __package__:                        # imported as benchmarks.records (the tests)
    from ._cli import alternating, lego_step_args, medians
    from .adam_step import measure
    from .lego import DATA
else:                                  # run as python benchmarks/records.py
    from _cli import alternating, lego_step_args, medians
    from adam_step import measure
    from lego import DATA

COMMAND = "python benchmarks/records.py"
CASES = {"degree 1": {}, "degree 2": {"sh_degree": 2}}
"""The colour records measured: the recipe's (12 floats) and harmonics of degree 2 (27 floats, padded to 32)."""


def main(argv=None) -> int:
    args = lego_step_args("records", __doc__, argv, DATA, 2)
    if args is None:
        return 0
    values, lines = {}, []
    for case, settings in CASES.items():
        runs = alternating(("packets", "floats"), args.repeats,
                           lambda mode: measure(args.data, "lean", {**settings, "color_packets": mode == "packets"}))
        v = medians(runs, ("steps_per_s", "peak_gib"))
        v.update(params=runs["packets"][0]["params"], step_ratio=v["packets_steps_per_s"] / v["floats_steps_per_s"],
                 settings=settings)
        values[case] = v
        lines.append(f"harmonics of {case} ({v['params'] / 1e6:.1f} M parameters): in packets "
                     f"{v['packets_steps_per_s']:.2f} steps/s, peak {v['packets_peak_gib']:.2f} GiB; float by float "
                     f"{v['floats_steps_per_s']:.2f} steps/s, peak {v['floats_peak_gib']:.2f} GiB "
                     f"(packets {v['step_ratio']:.2f}x)")
        print(lines[-1], flush=True)
    values["repeats"] = args.repeats
    record_result("records/lego", values, "lego 400, whole lattice, training steps: " + "; ".join(lines), COMMAND,
                  threads=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
