"""``mitnerf sweep --out DIR [--quick] [--workers N] [--threads T] [--executor local|dask]
[--scheduler ADDRESS] [--scenes ...] [--budgets ...] [--retry-failed] [--seed S]``.

Speed against accuracy (:mod:`mitnerf.experiments.sweep`): writes ``sweep.csv``,
``sweep.md`` and ``pareto.png`` into ``DIR``; running it again skips the finished rows.
"""

from __future__ import annotations

from pathlib import Path

from .._io import Output
from ..errors import ConfigError
from ..experiments.sweep import BUDGETS, SCENES, Config, build_rows, parse_budget, run as run_sweep
from .args import number


def register(sub) -> None:
    p = sub.add_parser("sweep", help="train a grid of configurations; test PSNR against wall time, Pareto front")
    p.add_argument("--out", required=True, help="output folder (sweep.csv, sweep.md, pareto.png)")
    p.add_argument("--overwrite", action="store_true", help="write into a folder that holds other files")
    p.add_argument("--quick", action="store_true", help="tiny rigs, tiny models, a few steps (a smoke test)")
    p.add_argument("--workers", type=number(True, 1, 256), default=1, help="parallel runs; workers x threads <= cores")
    p.add_argument("--threads", type=number(True, 1, 256), default=2, help="CPU threads per run")
    p.add_argument("--executor", choices=["local", "dask"], default="local",
                   help="local: a pool of processes; dask: a distributed cluster (needs --scheduler)")
    p.add_argument("--scheduler", default=None, help="Dask scheduler address, e.g. tcp://10.0.0.5:8786")
    p.add_argument("--scenes", nargs="+", default=list(SCENES), help=f"scenes (default: {' '.join(SCENES)})")
    p.add_argument("--budgets", nargs="+", default=None,
                   help=f"training budgets, seconds '20s' or steps '500it' (default: {' '.join(BUDGETS)})")
    p.add_argument("--no-reference", action="store_true", help="leave out the 600 s torch reference on bunny")
    p.add_argument("--retry-failed", action="store_true", help="rerun rows recorded as failed")
    p.add_argument("--seed", type=number(True, 0, 2 ** 31), default=0)
    p.set_defaults(run=run)


def run(args) -> int:
    for b in args.budgets or []:
        parse_budget(b)
    cfg = Config(scenes=tuple(args.scenes), budgets=tuple(args.budgets) if args.budgets else None,
                 reference=not args.no_reference, workers=args.workers, threads=args.threads,
                 executor=args.executor, scheduler=args.scheduler, quick=args.quick, seed=args.seed,
                 retry_failed=args.retry_failed)
    if cfg.executor == "dask" and not cfg.scheduler:
        raise ConfigError("--executor dask needs --scheduler ADDRESS (start one with 'dask scheduler')")
    build_rows(cfg)                                          # refuses unknown scenes before anything is written
    out = Output(Path(args.out), "sweep", args.overwrite).claim()
    rows = run_sweep(cfg, out)
    failed = sum(r["status"] != "ok" for r in rows)
    print(f"{len(rows)} runs ({failed} failed); wrote {out / 'sweep.csv'}, {out / 'sweep.md'}, {out / 'pareto.png'}")
    return 0
