"""From a folder of photographs to a video, in three commands: the camera poses by structure from motion
(`mitnerf poses`, COLMAP through pycolmap: `pip install -e .[poses]`), a fit (`mitnerf fit`, the default
recipe for the data) and a video of the fitted field (`mitnerf video`). Each command is printed before it runs.

    python examples/photos_to_video.py --images PHOTOS [--out out/photos] [--time-budget 600] [--downscale N]
                                       [--camera-model SIMPLE_RADIAL|OPENCV|...]
    python examples/photos_to_video.py --images ../shared/data/llff/fern/images_4 --downscale 2
    python examples/photos_to_video.py --images ../shared/data/instant_ngp/fox/images --downscale 4 \
        --camera-model OPENCV

Writes OUT/data (the photographs with their poses: a nerfstudio transforms.json), OUT/run (the fit) and OUT/video
(color and depth as GIF and MP4). ``--downscale N`` trains on the photographs N times smaller (poses are found
on the originals). Last line: `mitnerf video`'s (``video <n> frames <W>x<H> in <t> s ...``).
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from mitnerf.cli import main as cli

ROOT = Path(__file__).resolve().parents[1]


def run(*args) -> int:
    """``mitnerf ARGS``, printed first."""
    print("$ mitnerf " + " ".join(shlex.quote(str(a)) for a in args), flush=True)
    return cli([str(a) for a in args])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--images", required=True, help="the folder of photographs (one size, .jpg or .png)")
    p.add_argument("--out", default=str(ROOT / "out" / "photos"), help="where data/, run/ and video/ go")
    p.add_argument("--time-budget", type=float, default=600.0, help="seconds of training (default: 600)")
    p.add_argument("--downscale", type=int, default=1, help="train on the photographs N times smaller (default: 1)")
    p.add_argument("--camera-model", default="SIMPLE_RADIAL", help="COLMAP's lens model (default: SIMPLE_RADIAL)")
    a = p.parse_args(argv)
    out = Path(a.out)                   # a rerun replaces these outputs of its own
    return (run("poses", "--images", a.images, "--out", out / "data", "--downscale", a.downscale, "--camera-model",
                a.camera_model)
            or run("fit", "--data", out / "data", "--out", out / "run", "--time-budget", a.time_budget)
            or run("video", "--checkpoint", out / "run", "--out", out / "video", "--no-mesh"))


if __name__ == "__main__":
    sys.exit(main())
