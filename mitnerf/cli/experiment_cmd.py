"""``mitnerf experiment NAME --out DIR [--quick] [--seed S] [--set KEY=VALUE ...]``.

Runs one experiment of :mod:`mitnerf.experiments` into ``DIR`` (CSV, figures,
``report.md``); ``--set`` changes one field of the experiment's ``Config``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from .._io import Output
from ..errors import ConfigError, check_number
from ..experiments import EXPERIMENTS
from .args import key_value, number


def register(sub) -> None:
    p = sub.add_parser("experiment", help="run an experiment; writes CSV, figures and report.md")
    p.add_argument("name", choices=list(EXPERIMENTS))
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
    module = EXPERIMENTS[args.name]
    cfg = configure(module, args.quick, args.seed, args.sets)
    out = Output(Path(args.out), f"experiment {args.name}", args.overwrite).claim()
    module.run(cfg, out)
    print(f"wrote {out / 'report.md' if (out / 'report.md').exists() else out}")
    return 0
