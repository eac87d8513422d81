"""``mitnerf experiment NAME --out DIR [--quick] [--seed S] [--set KEY=VALUE ...]``: one experiment into ``DIR``
(CSV, figures, ``report.md``); ``--set`` changes one field of its ``Config``. A full run (not ``--quick``) of one
that tests the source reports records its rows, command and machine in the results file; ``experiment all`` runs
those at full size, each into ``DIR/<name>``, and writes ``DIR/REPRODUCTION.md``.

``mitnerf sweep --out DIR [--quick] [--workers N] [--executor local|dask] ...``: speed against accuracy; writes
``sweep.csv``, ``sweep.md`` and ``pareto.png`` into ``DIR``; running it again skips the finished rows."""

from __future__ import annotations

import dataclasses
import json
import shlex
import time
from pathlib import Path

from .._io import Output
from ..errors import ConfigError, check_number
from ..experiments import EXPERIMENTS
from ..experiments.reproduction import REPRODUCE, record, write
from ..experiments.sweep import BUDGETS, SCENES, Config, build_rows, parse_budget, run as sweep_rows
from ..results import load_results
from .args import key_value, number


def register(sub) -> None:
    p = sub.add_parser("experiment", help="run an experiment; writes CSV, figures and report.md")
    p.add_argument("name", choices=[*EXPERIMENTS, "all"])
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--overwrite", action="store_true", help="write into a folder that holds other files")
    p.add_argument("--quick", action="store_true", help="a small version (about a minute)")
    p.add_argument("--seed", type=number(True, 0, 2 ** 31), default=0)
    p.add_argument("--set", dest="sets", action="append", default=[], type=key_value, metavar="KEY=VALUE",
                   help="change one setting of the experiment's Config (repeatable)")
    p.set_defaults(run=run_experiment)
    p = sub.add_parser("sweep", help="train a grid of configurations; test PSNR against wall time, Pareto front")
    p.add_argument("--out", required=True, help="output folder (sweep.csv, sweep.md, pareto.png)")
    p.add_argument("--overwrite", action="store_true", help="write into a folder that holds other files")
    p.add_argument("--quick", action="store_true", help="tiny rigs, tiny models, a few steps (a smoke test)")
    p.add_argument("--workers", type=number(True, 1, 256), default=1, help="parallel runs; workers x threads <= cores")
    p.add_argument("--threads", type=number(True, 1, 256), default=2, help="CPU threads per run")
    p.add_argument("--executor", choices=["local", "dask"], default="local",
                   help="local: a pool of processes; dask: a distributed cluster (needs --scheduler)")
    p.add_argument("--scheduler", help="Dask scheduler address, e.g. tcp://10.0.0.5:8786")
    p.add_argument("--scenes", nargs="+", default=list(SCENES), help=f"scenes (default: {' '.join(SCENES)})")
    p.add_argument("--budgets", nargs="+",
                   help=f"training budgets, seconds '20s' or steps '500it' (default: {' '.join(BUDGETS)})")
    p.add_argument("--no-reference", action="store_true", help="leave out the 600 s torch reference on bunny")
    p.add_argument("--retry-failed", action="store_true", help="rerun rows recorded as failed")
    p.add_argument("--seed", type=number(True, 0, 2 ** 31), default=0)
    p.set_defaults(run=run_sweep)


def configure(module, quick: bool, seed: int, sets: list) -> object:
    """The experiment's config with the ``--set`` values, each checked against its default (type; > 0 where it is)."""
    cfg = module.quick(seed) if quick else module.Config(seed=seed)
    fields = {f.name: f for f in dataclasses.fields(cfg)}
    for key, value in sets:
        if key not in fields:
            raise ConfigError(f"the experiment has no setting {key!r}; its settings are {', '.join(sorted(fields))}")
        old = getattr(cfg, key)
        if isinstance(old, (tuple, list)) and isinstance(value, list):
            value = tuple(value)
        elif isinstance(old, bool) or isinstance(value, bool):
            if type(value) is not type(old):
                raise ConfigError(f"--set {key} must be true or false, got {value!r}")
        elif isinstance(old, (int, float)):
            check_number(key, value, 0, None, integer=isinstance(old, int) and not isinstance(old, bool),
                         strict_lo=old > 0, flag=f"--set {key}")
        elif old is not None and type(value) is not type(old):
            raise ConfigError(f"--set {key} must be like {old!r}, got {value!r}")
        setattr(cfg, key, value)
    return cfg


def run_experiment(args) -> int:
    names = REPRODUCE if args.name == "all" else (args.name,)
    if args.name == "all" and args.sets:
        raise ConfigError("--set applies to one experiment; run `mitnerf experiment NAME --set ...` instead of all")
    cfgs = {n: configure(EXPERIMENTS[n], args.quick, args.seed, args.sets) for n in names}
    target = Output(Path(args.out), f"experiment {args.name}", args.overwrite, incremental=True)
    out = target.claim()
    sets = [shlex.quote(f"{k}={v if isinstance(v, str) else json.dumps(v)}") for k, v in args.sets]
    command = " ".join(["mitnerf experiment", args.name, "--out", shlex.quote(args.out)]
                       + (["--seed", str(args.seed)] if args.seed else []) + [f"--set {s}" for s in sets])
    for n in names:
        where = out / n if args.name == "all" else out
        where.mkdir(exist_ok=True)
        t0 = time.perf_counter()
        rows = EXPERIMENTS[n].run(cfgs[n], where)
        if not args.quick and n in REPRODUCE:
            record(n, cfgs[n], rows, time.perf_counter() - t0, command)
        print(f"wrote {where / 'report.md' if (where / 'report.md').exists() else where}", flush=True)
    if args.name == "all":
        print(f"wrote {write(load_results(), out, command)}")
    target.release()
    return 0


def run_sweep(args) -> int:
    for b in args.budgets or []:
        parse_budget(b)
    cfg = Config(scenes=tuple(args.scenes), budgets=tuple(args.budgets) if args.budgets else None,
                 reference=not args.no_reference, workers=args.workers, threads=args.threads,
                 executor=args.executor, scheduler=args.scheduler, quick=args.quick, seed=args.seed,
                 retry_failed=args.retry_failed)
    if cfg.executor == "dask" and not cfg.scheduler:
        raise ConfigError("--executor dask needs --scheduler ADDRESS (start one with 'dask scheduler')")
    build_rows(cfg)                                          # refuses unknown scenes before anything is written
    target = Output(Path(args.out), "sweep", args.overwrite, incremental=True)
    out = target.claim()
    try:
        rows = sweep_rows(cfg, out)
    except KeyboardInterrupt as exc:
        exc.note = f"; the finished rows are in {out}: run the same command to continue"
        raise
    target.release()
    failed = sum(r["status"] != "ok" for r in rows)
    print(f"{len(rows)} runs ({failed} failed); wrote {out / 'sweep.csv'}, {out / 'sweep.md'}, {out / 'pareto.png'}")
    return 0
