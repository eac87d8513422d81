"""Positional-encoding ablation on the bunny (L = 0 .. 10): PSNR and train time per L, the density fields side by side.

    python examples/pe_ablation.py [--quick] [--out out/experiments/pe] [--seed 0]

Writes CSV files, PNG figures and report.md (see `mitnerf.experiments`); how long the default size
takes is recorded as `experiment/pe` in results.json; `--quick` is a smoke run of a few steps.
"""

import sys

from mitnerf.cli import example_main

if __name__ == "__main__":
    sys.exit(example_main("pe", __doc__))
