"""Positional-encoding ablation on the bunny (L = 0 .. 10): PSNR and train time per L, the density fields side by side.

    python examples/pe_ablation.py [--quick] [--out out/experiments/pe] [--seed 0]

Writes CSV files, PNG figures and report.md (see `mitnerf.experiments`); the default
size takes up to 15 minutes on 2 cores, `--quick` about 1-2 minutes.
"""

import sys

from mitnerf.cli import example_main

if __name__ == "__main__":
    sys.exit(example_main("pe", __doc__))
