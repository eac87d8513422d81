"""``mitnerf experiment NAME --out DIR [--quick] [--seed S] [--set KEY=VALUE ...]``.

Runs one experiment of :mod:`mitnerf.experiments` into ``DIR`` (CSV, figures,
``report.md``); ``--set`` changes one field of the experiment's ``Config``. A full run
(not ``--quick``) of an experiment that tests the source reports records its rows, the
command and the machine in the results file (:mod:`mitnerf.experiments.reproduction`).

``mitnerf experiment all --out DIR`` runs those experiments at full size, each into
``DIR/<name>``, and writes ``DIR/REPRODUCTION.md``.
"""

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
    p.set_defaults(run=run)


def configure(module, quick: bool, seed: int, sets: list) -> object:
    """The experiment's config with the ``--set`` values, each checked against its default: the
    same type, and positive where the default is (a count, a budget, a size)."""
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


def run(args) -> int:
    names = REPRODUCE if args.name == "all" else (args.name,)
    if args.name == "all" and args.sets:
        raise ConfigError("--set applies to one experiment; run `mitnerf experiment NAME --set ...` instead of all")
    cfgs = {n: configure(EXPERIMENTS[n], args.quick, args.seed, args.sets) for n in names}
    out = Output(Path(args.out), f"experiment {args.name}", args.overwrite).claim()
    command = " ".join(["mitnerf experiment", args.name, "--out", shlex.quote(args.out)]
                       + (["--seed", str(args.seed)] if args.seed else [])
                       + [f"--set {shlex.quote(f'{k}={v if isinstance(v, str) else json.dumps(v)}')}" for k, v in args.sets])
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
    return 0
