"""Window shopping in 3D: a few photos of a product in, a turn-table video and a mesh out.

Three commands, run here one after the other:

1. photos: `mitnerf dataset --scene SCENE --views N --out DATA` (25 photos of the vase,
   100 x 100, on the upper hemisphere; skipped with `--data` for your own folder or
   tiny-NeRF file);
2. train: `mitnerf fit --data DATA --out OUT/checkpoint [fit flags]` (the default 3D
   recipe: a dense grid with an occupancy grid, 60 s); the last line is its test PSNR;
3. watch: `mitnerf video --checkpoint OUT/checkpoint --out OUT/video` (a 360 degree orbit
   as GIF and MP4, colour and depth; the density's mesh beside the true one and, for our
   objects, the Chamfer distance).

    python examples/window_shopping.py [--scene vase] [--views 25] [--data PATH] [--out out/window_shopping]
                                       [fit flags, e.g. --field hashgrid --time-budget 120]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mitnerf.cli import main as cli

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default="vase", help="a 3D object of ours")
    p.add_argument("--views", type=int, default=25, help="photos to train on")
    p.add_argument("--data", default=None, help="your own dataset instead (transforms.json folder or tiny-NeRF .npz)")
    p.add_argument("--out", default=str(ROOT / "out" / "window_shopping"))
    p.add_argument("--frames", default="120", help="video frames")
    args, fit_flags = p.parse_known_args(argv)
    data = args.data or str(ROOT / "out" / "datasets" / f"{args.scene}-{args.views}")
    if args.data is None and not Path(data).exists():
        rc = cli(["dataset", "--scene", args.scene, "--views", str(args.views), "--out", data])
        if rc:
            return rc
    out = Path(args.out)
    return (cli(["fit", "--data", data, "--out", str(out / "checkpoint"), *fit_flags])
            or cli(["video", "--checkpoint", str(out / "checkpoint"), "--out", str(out / "video"),
                    "--frames", args.frames]))


if __name__ == "__main__":
    sys.exit(main())
