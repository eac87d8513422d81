"""Render a NeRF2D dataset of the bunny and write its pictures.

    python examples/make_dataset.py [--scene bunny] [--out out/datasets/bunny]

Writes the dataset (NeRF2D format for 2D scenes, Blender format for 3D objects) and,
under ``OUT/figures``, the views strip, the depth strip and the camera-rig plot.
"""

from __future__ import annotations

import argparse
import sys

from mitnerf.cli import main as cli

if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default="bunny")
    p.add_argument("--out", default=None)
    a = p.parse_args()
    out = a.out or f"out/datasets/{a.scene}"
    rc = cli(["dataset", "--scene", a.scene, "--out", out]) or cli(["show", out])
    sys.exit(rc)
