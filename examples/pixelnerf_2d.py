"""pixelNeRF in 2D against NeRF with 1, 3, 5 and 9 input views (bunny and tu, never trained on).

    python examples/pixelnerf_2d.py [--quick] [--out out/experiments/pixelnerf] [--seed 0]

The same run as `mitnerf experiment pixelnerf` (see `mitnerf.experiments.pixelnerf`).
"""

import sys

from mitnerf.cli import example_main

if __name__ == "__main__":
    sys.exit(example_main("pixelnerf", __doc__))
