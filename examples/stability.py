"""Stability from sparse views: 20 seeds per method, collapse rates, failure modes.

    python examples/stability.py [--quick] [--out out/experiments/stability] [--seed 0]

Writes CSV files, PNG figures and report.md (see `mitnerf.experiments`); the default
size takes up to 15 minutes on 2 cores, `--quick` about 1-2 minutes.
"""

from __future__ import annotations

import argparse
import sys

from mitnerf.cli import main as cli

if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--out", default="out/experiments/stability")
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args()
    sys.exit(cli(["experiment", "stability", "--out", a.out, "--seed", str(a.seed)] + (["--quick"] if a.quick else [])))
