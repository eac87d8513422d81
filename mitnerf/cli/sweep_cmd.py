"""``mitnerf sweep --out DIR [--quick] [--workers N] [--threads T] [--executor local|dask]
[--scheduler ADDRESS] [--scenes ...] [--budgets ...] [--retry-failed] [--seed S]``.

Speed against accuracy (:mod:`mitnerf.experiments.sweep`): writes ``sweep.csv``,
``sweep.md`` and ``pareto.png`` into ``DIR``; running it again skips the finished rows.
"""

from __future__ import annotations

from pathlib import Path


def register(sub) -> None:
    from ..experiments.sweep import BUDGETS, SCENES

    p = sub.add_parser("sweep", help="train a grid of configurations; test PSNR against wall time, Pareto front")
    p.add_argument("--out", required=True, help="output folder (sweep.csv, sweep.md, pareto.png)")
    p.add_argument("--quick", action="store_true", help="tiny rigs, one tiny model, a few steps (a smoke test)")
    p.add_argument("--workers", type=int, default=1, help="parallel runs (local executor); workers x threads <= cores")
    p.add_argument("--threads", type=int, default=2, help="CPU threads per run")
    p.add_argument("--executor", choices=["local", "dask"], default="local",
                   help="local: a pool of processes; dask: a distributed cluster (needs --scheduler)")
    p.add_argument("--scheduler", default=None, help="Dask scheduler address, e.g. tcp://10.0.0.5:8786")
    p.add_argument("--scenes", nargs="+", default=list(SCENES), help=f"scenes (default: {' '.join(SCENES)})")
    p.add_argument("--budgets", nargs="+", default=None,
                   help=f"training budgets, seconds '20s' or steps '500it' (default: {' '.join(BUDGETS)})")
    p.add_argument("--no-reference", action="store_true", help="leave out the 600 s torch reference on bunny")
    p.add_argument("--retry-failed", action="store_true", help="rerun rows recorded as failed")
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(run=run)


def config_from_args(args):
    from ..errors import MitnerfError
    from ..experiments.sweep import SweepConfig, parse_budget

    if args.workers < 1 or args.threads < 1:
        raise MitnerfError("--workers and --threads must be at least 1; try --workers 1 --threads 2")
    if args.executor == "dask" and not args.scheduler:
        raise MitnerfError("--executor dask needs --scheduler ADDRESS (start one with 'dask scheduler')")
    for b in args.budgets or []:
        parse_budget(b)
    return SweepConfig(out=Path(args.out), scenes=list(args.scenes), budgets=args.budgets,
                       reference=not args.no_reference, workers=args.workers, threads=args.threads,
                       executor=args.executor, scheduler=args.scheduler, quick=args.quick, seed=args.seed,
                       retry_failed=args.retry_failed)


def run(args) -> int:
    from ..experiments.sweep import run_sweep

    res = run_sweep(config_from_args(args))
    print(f"{res.ran} runs ({res.failed} failed), {res.skipped} already done; wrote {res.csv}, {res.report}, "
          f"{res.chart}")
    return 0
