"""Stability from sparse views: 20 seeds per method, collapse rates, failure modes.

    python examples/stability.py [--quick] [--out out/experiments/stability] [--seed 0]

Writes CSV files, PNG figures and report.md (see `mitnerf.experiments`); how long the default size
takes is printed at its end; `--quick` is a smoke run of a few steps.
"""

import sys

from mitnerf.cli import example_main

if __name__ == "__main__":
    sys.exit(example_main("stability", __doc__))
