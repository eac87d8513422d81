"""``mitnerf`` / ``python -m mitnerf``: one sub-command per job.

Bad input ends with one line naming the problem and the fix, and exit status 2.
"""

from __future__ import annotations

import argparse
import sys

from ..errors import MitnerfError
from . import data_cmds, experiment_cmd, fit_cmd, sweep_cmd, video_cmd

COMMANDS = [data_cmds, fit_cmd, experiment_cmd, sweep_cmd, video_cmd]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="mitnerf", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    for module in COMMANDS:
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except MitnerfError as exc:
        print(f"mitnerf: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
