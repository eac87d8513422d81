"""``mitnerf experiment NAME --out DIR [--quick] [--seed S] [--set KEY=VALUE ...]`` (:mod:`mitnerf.experiments`; a
full run of one of :data:`~mitnerf.experiments.reproduction.REPRODUCE` records its rows in the results file, a run of
part of it (``--set`` on a setting that chooses its runs) leaves the record alone, and
``experiment all`` runs them all: :mod:`~mitnerf.experiments.reproduction`) and ``mitnerf sweep --out DIR ...``
(:mod:`~mitnerf.experiments.sweep`)."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
import shlex
import time
from pathlib import Path

from .._io import Output
from ..errors import ConfigError
from ..experiments import EXPERIMENTS
from ..experiments.reproduction import REPRODUCE, partial, record, write
from ..experiments.sweep import Config, build_rows, parse_budget, run as sweep_rows
from ..results import load_results
from ..settings import check, check_value, field_named, parse_set, setting
from .args import Writes, add_command, options, parse


@dataclass(kw_only=True)
class ExperimentCommand(Writes):
    """``mitnerf experiment``: one experiment of the source reports, or all of them."""

    name: str = setting(flag="name", choices=(*EXPERIMENTS, "all"))
    """The experiment (all: the four that test the source reports, then REPRODUCTION.md)."""
    out: str = setting(flag="--out", metavar="DIR")
    """Output folder (CSV, figures, report.md)."""
    quick: bool = setting(False, flag="--quick")
    """A smoke run of a few steps: its report draws no conclusions."""
    seed: int = setting(0, lo=0, hi=2 ** 31, flag="--seed")
    """Seed of the experiment's data and runs."""


@dataclass(kw_only=True)
class SweepCommand(Writes):
    """``mitnerf sweep``: speed against accuracy (the sweep's options: :class:`~mitnerf.experiments.sweep.Config`)."""

    out: str = setting(flag="--out", metavar="DIR")
    """Output folder (sweep.csv, sweep.md, pareto.png); a rerun skips the finished rows."""


def register(sub) -> None:
    p = add_command(sub, "experiment", ExperimentCommand, run_experiment,
                    help="run an experiment; writes CSV, figures and report.md")
    p.add_argument("--set", dest="sets", action="append", default=[], type=parse_set, metavar="KEY=VALUE",
                   help="change one setting of the experiment's Config; repeatable, the value in JSON (default: "
                        "the experiment's)")
    add_command(sub, "sweep", SweepCommand, run_sweep, (Config, "sweep."),
                help="train a grid of configurations: test PSNR against wall time, the Pareto front")


def configure(module, quick: bool, seed: int, sets: list) -> object:
    """The experiment's config with the ``--set`` values, each checked by its declaration."""
    cfg = module.quick(seed) if quick else module.Config(seed=seed)
    for key, value in sets:
        f = field_named(type(cfg), key)
        if f is None:
            names = ", ".join(sorted(g.name for g in dataclasses.fields(cfg)))
            raise ConfigError(f"the experiment has no setting {key!r}; its settings are {names}")
        setattr(cfg, key, check_value(type(cfg), f, value))
    return cfg


def run_experiment(args) -> int:
    sets, args = args.sets, parse(args)
    names = REPRODUCE if args.name == "all" else (args.name,)
    if args.name == "all" and sets:
        raise ConfigError("--set applies to one experiment; run `mitnerf experiment NAME --set ...` instead of all")
    cfgs = {n: configure(EXPERIMENTS[n], args.quick, args.seed, sets) for n in names}
    target = Output(Path(args.out), f"experiment {args.name}", args.overwrite, incremental=True)
    out = target.claim()
    sets = [shlex.quote(f"{k}={v if isinstance(v, str) else json.dumps(v)}") for k, v in sets]
    command = " ".join(["mitnerf experiment", args.name, "--out", shlex.quote(args.out)]
                       + (["--seed", str(args.seed)] if args.seed else []) + [f"--set {s}" for s in sets])
    for n in names:
        where = out / n if args.name == "all" else out
        where.mkdir(exist_ok=True)
        t0 = time.perf_counter()
        try:
            rows = EXPERIMENTS[n].run(cfgs[n], where)
        except KeyboardInterrupt as exc:
            done = names[:names.index(n)]
            exc.note = f"; finished and kept in {out}: {', '.join(done)}" if done else ""
            raise
        if not args.quick and n in REPRODUCE and record(n, cfgs[n], rows, time.perf_counter() - t0, command) is None:
            print(f"not recorded in the results file: --set {', '.join(partial(cfgs[n]))} runs part of experiment "
                  f"{n}; its record stays", flush=True)
        print(f"wrote {where / 'report.md' if (where / 'report.md').exists() else where}", flush=True)
    if args.name == "all":
        print(f"wrote {write(load_results(), out, command)}")
    target.release()
    return 0


def run_sweep(args) -> int:
    cfg, args = Config(**options(Config, args, "sweep.")), parse(args)
    check(cfg)
    for b in cfg.budgets or []:
        parse_budget(b)
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
