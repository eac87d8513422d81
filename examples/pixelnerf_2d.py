"""pixelNeRF in 2D against NeRF with 1, 3, 5 and 9 input views (bunny and tu, never trained on).

Trains a 2D pixelNeRF (frozen and trained 1D CNN encoders) across procedural outlines,
fits a NeRF per scene and view count, and writes under ``--out``: ``results.csv``,
``training.csv``, ``training.png``, ``psnr_vs_views.png``, ``strips_<scene>.png``, ``density_<scene>.png``
and ``report.md``. The full run takes at most ~15 minutes on 2 cores, ``--quick`` ~2.

    python examples/pixelnerf_2d.py [--quick] [--seed S] [--field F] [--out DIR]

Last line: ``wrote <out>/report.md (<t> s)``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import mitnerf  # noqa: F401
from mitnerf.experiments.pixelnerf import PixelNeRFExperimentConfig, quick_config, run
from mitnerf.train.presets import preset_fields

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="small budgets (about 2 minutes)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--field", choices=preset_fields(), default="vanilla", help="field family of the NeRF baselines")
    p.add_argument("--out", default=None, help="default: out/pixelnerf_2d[_quick]")
    args = p.parse_args(argv)

    cfg = quick_config() if args.quick else PixelNeRFExperimentConfig()
    cfg.field = args.field
    out = Path(args.out or ROOT / "out" / ("pixelnerf_2d_quick" if args.quick else "pixelnerf_2d"))
    t0 = time.perf_counter()
    report = run(out, quick=args.quick, seed=args.seed, config=cfg)
    print(f"wrote {report} ({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
