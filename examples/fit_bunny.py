"""Fit the 2D bunny: NeRF2D's protocol (50 noisy training views of 100 px) on 2 cores.

Renders the dataset once (`mitnerf dataset --scene bunny --out DATA`), then runs exactly
`mitnerf fit --data DATA --out OUT [your flags]`: with no flags, the default 2D recipe
(`mitnerf recipes`), which prints itself first. Writes the checkpoint, metrics, test views
beside ground truth, the depth strip, the density field and the training curves.

    python examples/fit_bunny.py [--data out/datasets/bunny] [--out out/fit_bunny] [fit flags...]

Last line: `test PSNR <x> dB, ...` (see `mitnerf fit`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mitnerf.cli import main as cli

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", default=str(ROOT / "out" / "datasets" / "bunny"), help="the bunny dataset (made if absent)")
    p.add_argument("--out", default=str(ROOT / "out" / "fit_bunny"), help="checkpoint and figures")
    args, fit_flags = p.parse_known_args(argv)
    if not Path(args.data).exists():
        rc = cli(["dataset", "--scene", "bunny", "--out", args.data])
        if rc:
            return rc
    return cli(["fit", "--data", args.data, "--out", args.out, *fit_flags])


if __name__ == "__main__":
    sys.exit(main())
