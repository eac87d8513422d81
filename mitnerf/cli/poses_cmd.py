"""``mitnerf poses --images DIR --out DATA``: camera poses of a folder of photographs by structure from motion
(COLMAP through pycolmap, :mod:`mitnerf.data.sfm`), written as a dataset that ``mitnerf fit`` and nerfstudio read.
The last line reads ``wrote DATA (<n> of <m> images posed, <k> points; near <a>, far <b>) in <t> s``."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

from .._io import Output
from ..data.sfm import SfmConfig, find_images, need_pycolmap, pose_capture
from ..settings import setting
from .args import Writes, add_command, options, parse

SIFT_BYTES = 200
"""Bytes the feature database holds per SIFT feature (its descriptor, keypoint and index)."""


@dataclass(kw_only=True)
class PosesCommand(Writes):
    """``mitnerf poses``: camera poses of photographs by structure from motion (COLMAP's options:
    :class:`~mitnerf.data.sfm.SfmConfig`)."""

    images: str = setting(flag="--images", metavar="DIR")
    """Folder of photographs (.png, .jpg) of one size; they are copied, never changed."""
    out: str = setting(flag="--out", metavar="DATA")
    """Output dataset folder: new, empty, or an earlier one of mitnerf's."""


def register(sub) -> None:
    add_command(sub, "poses", PosesCommand, run, (SfmConfig, "sfm."),
                help="camera poses of a folder of photographs by structure from motion (COLMAP)")


def run(args) -> int:
    cfg, args = SfmConfig(**options(SfmConfig, args, "sfm.")), parse(args)
    cfg.validate()
    need_pycolmap()
    start = time.perf_counter()
    files = find_images(args.images)
    size = sum(os.path.getsize(p) for p in files) * (1 + (cfg.downscale > 1)) + len(files) * cfg.max_features * \
        SIFT_BYTES
    target = Output(args.out, "dataset", args.overwrite, inputs=[args.images], size=size)
    with target.staged() as tmp:
        meta = pose_capture(files, tmp, cfg)
    info = meta["poses"]
    print(f"wrote {target.path} ({info['registered']} of {info['images']} images posed, {info['points']:,} points; "
          f"near {meta['near']:.3g}, far {meta['far']:.3g}) in {time.perf_counter() - start:.0f} s")
    return 0
