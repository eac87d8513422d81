"""A sub-command is a dataclass: its fields (made with :func:`mitnerf.settings.setting`, each with its flag and
the string under it as its help) are the command's options; configs of the library add theirs beside them."""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass

from ..settings import add_flags, check, setting


@dataclass(kw_only=True)
class Writes:
    """What every command that writes an output folder takes."""

    overwrite: bool = setting(False, flag="--overwrite")
    """Write into a folder that holds other files (they are left alone)."""


def add_command(sub, name: str, cls, run, *configs, help: str) -> argparse.ArgumentParser:
    """The sub-command ``name``: the flags of the dataclass ``cls`` and of each ``(config class, prefix[, shown])``
    in ``configs`` (their flags unset hold None: the config's own default, named by ``shown(key)`` or else the
    declaration's, applies)."""
    p = sub.add_parser(name, help=help, description=f"{help[0].upper()}{help[1:]}.")
    add_flags(p, cls)
    for config, prefix, *shown in configs:
        add_flags(p, config, prefix=prefix, overrides=True, shown=shown[0] if shown else None)
    p.set_defaults(run=run, command=cls)
    return p


def options(cls, args, prefix: str = "") -> dict:
    """The values of ``cls``'s fields in the parsed ``args`` (a config's: only the flags given)."""
    given = vars(args)
    return {f.name: given[prefix + f.name] for f in dataclasses.fields(cls)
            if prefix + f.name in given and (given[prefix + f.name] is not None or not prefix)}


def parse(args):
    """The command's dataclass, filled from ``args`` and checked."""
    cmd = args.command(**options(args.command, args))
    check(cmd)
    return cmd
