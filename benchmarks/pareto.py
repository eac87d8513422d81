"""Speed against accuracy: the default sweep, its Pareto fronts, and the 1/100 goal.

Runs ``mitnerf sweep`` (:mod:`mitnerf.experiments.sweep`: the vanilla, grid and hash-grid
recipes at two sizes x 32/64/128 samples x 3/10/30 s, the recipes on torch too, plus the
torch reference, ``vanilla-2d`` on torch for 600 s on bunny), prints each scene's front and
whether some configuration reaches the reference's test PSNR in 1/100 of its wall time, and
records that verdict in the results file. ``--scenes bunny`` (the reference scene alone) is enough for
the verdict; running it again resumes. ``--quick`` is a smoke test (it prints no verdict).

    python benchmarks/pareto.py [--out out/pareto] [--scenes bunny ...] [--quick] [sweep flags]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mitnerf.cli import main as cli
from mitnerf.experiments.claims import reference_verdict
from mitnerf.experiments.report import pareto_front
from mitnerf.experiments.sweep import SCENES, read_results
from mitnerf.results import record_result

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(ROOT / "out" / "pareto"))
    p.add_argument("--scenes", nargs="+", default=list(SCENES))
    p.add_argument("--quick", action="store_true")
    p.add_argument("--threads", type=int, default=2, help="CPU threads of each run")
    args, rest = p.parse_known_args(argv)
    rc = cli(["sweep", "--out", args.out, "--scenes", *args.scenes, "--threads", str(args.threads),
              *(["--quick"] if args.quick else []), *rest])
    if rc:
        return rc
    rows = read_results(Path(args.out) / "sweep.csv")
    for scene in args.scenes:
        print(f"\n{scene}: Pareto front (test PSNR against wall time)")
        for r in pareto_front([r for r in rows if r["scene"] == scene]):
            print(f"  {float(r['wall_time']):8.2f} s  {float(r['psnr']):6.2f} dB  {r['family']} {r['size']} "
                  f"s{r['samples']} {r['backend']} {r['budget']}")
    if args.quick:
        print("\na smoke run (--quick): no verdict")
        return 0
    verdict = reference_verdict(rows)
    print("\n" + verdict)
    if "Torch reference" in verdict:
        record_result("sweep/reference", {}, verdict.splitlines()[0] + " " + verdict.splitlines()[-1].strip("- "),
                      "python benchmarks/pareto.py --scenes " + " ".join(args.scenes), threads=args.threads)
    return 0


if __name__ == "__main__":
    sys.exit(main())
