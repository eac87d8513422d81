"""NeRF against DS-NeRF with 2, 5 and 10 evenly spaced views on square, square_concave, bunny and tu.

    python examples/depth_supervision.py [--quick] [--out out/experiments/depth] [--seed 0]

Writes CSV files, PNG figures and report.md (see `mitnerf.experiments`); how long the default size
takes is recorded as `experiment/depth` in results.json; `--quick` is a smoke run of a few steps.
"""

import sys

from mitnerf.cli import example_main

if __name__ == "__main__":
    sys.exit(example_main("depth", __doc__))
