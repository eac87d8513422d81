"""Speed against accuracy: the full default sweep, its Pareto fronts, and the 1/100 goal.

Runs ``mitnerf sweep`` with the default grid (:mod:`mitnerf.experiments.sweep`: the
vanilla, grid and hash-grid families, each at a small size and at its preset, x 32/64/128
samples x budgets 3/10/30 s, the presets on torch too, on bunny, square, tu and vase; plus
the torch reference: the vanilla preset on torch for 600 s on bunny), prints the Pareto
front of each scene, and says whether some configuration reaches the reference's test
PSNR in at most 1/100 of its wall time.

81 runs per scene, about 20 minutes per 2D scene on 2 cores (``--workers 1 --threads 2``,
the default), plus 10 minutes for the reference; ``--scenes bunny`` (30 minutes in all)
is enough for the 1/100 verdict. Interrupt it at will: running it again resumes (finished rows are
skipped). ``--quick`` is a one-minute smoke test.

    python benchmarks/pareto.py [--out out/pareto] [--workers 1] [--threads 2] [--quick]
                                [--executor dask --scheduler tcp://HOST:8786]

Last line: ``reference <p> dB in <t> s; fastest reaching it: <config> in <s> s (<x>x); goal 1/100: PASSED|NOT PASSED``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import mitnerf  # noqa: F401
from mitnerf.experiments.pareto import SPEEDUP, pareto_front, reference_verdict
from mitnerf.experiments.sweep import SCENES, SweepConfig, run_sweep
from mitnerf.experiments.sweep_exec import read_results

ROOT = Path(__file__).resolve().parents[1]


def describe(r: dict) -> str:
    return f"{r['family']} {r['size']} s{r['samples']} {r['backend']} {r['budget']}"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(ROOT / "out" / "pareto"))
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--executor", choices=["local", "dask"], default="local")
    p.add_argument("--scheduler", default=None)
    p.add_argument("--scenes", nargs="+", default=list(SCENES))
    p.add_argument("--quick", action="store_true", help="tiny rigs and models, a few steps")
    args = p.parse_args(argv)

    res = run_sweep(SweepConfig(out=Path(args.out), scenes=args.scenes, workers=args.workers, threads=args.threads,
                                executor=args.executor, scheduler=args.scheduler, quick=args.quick))
    rows = read_results(res.csv)
    print(f"{res.ran} runs now ({res.failed} failed), {res.skipped} from before; {res.report}")
    for scene in args.scenes:
        print(f"\n{scene}: Pareto front (test PSNR against wall time)")
        for r in pareto_front([r for r in rows if r["scene"] == scene]):
            print(f"  {float(r['wall_time']):8.2f} s  {float(r['psnr']):6.2f} dB  {describe(r)}")
    v = reference_verdict(rows)
    if v is None:
        print("\nno torch reference run (it runs on bunny)")
        return 1
    ref, f = v["reference"], v["fastest_reaching"]
    reach = f"{describe(f)} in {float(f['wall_time']):.2f} s ({v['speedup']:.1f}x)" if f else "none"
    print(f"\nreference {float(ref['psnr']):.2f} dB in {float(ref['wall_time']):.1f} s; fastest reaching it: {reach}; "
          f"goal 1/{SPEEDUP}: {'PASSED' if v['passed'] else 'NOT PASSED'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
