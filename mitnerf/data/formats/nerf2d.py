"""The NeRF2D format (the original NeRF2D code and its Blender add-on)::

    DIR/mitnerf.json                      (ours only: bounds and provenance)
    DIR/{train,val,test}/transforms.json  {"focal": f_px, "frames": [{"transform_matrix": 3x3}]}
    DIR/{split}/cam-{i}.png               H x 1 RGBA, 8-bit sRGB, colour over black + coverage
    DIR/{split}/cam-{i}.npz               depth_map (H x 1, -1 on a miss), intrinsic_mat (3x3)

Frame ``i`` of ``transforms.json`` belongs to ``cam-{i}.*``; rays as in :mod:`mitnerf.data.cameras`. Our
``.npz`` files add ``rgb_linear``, ``alpha`` and ``mask``, which the original loader ignores; folders from
the add-on load without them (and may store images as ``1 x H`` rows).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from ...errors import DataError
from ..cameras import Cameras
from ..color import display_color
from ..dataset import SPLITS, Dataset, Split, bounds_from_cameras
from .capture import check_downscale
from .common import (all_or_none, as_rgba, check_focal, get, read_poses, read_json, read_meta, read_npz, read_view,
                     view_size, write_meta, write_png)


def write_nerf2d(dataset: Dataset, folder: Path) -> None:
    """Write ``dataset`` (2D) into the (new, empty) ``folder``."""
    if dataset.dim != 2:
        raise DataError("the NeRF2D format holds 2D datasets only; use --format blender or nerfstudio for 3D")
    if not all(s.cameras.simple for s in dataset.splits.values()):
        raise DataError("the NeRF2D format holds one focal length per split and centred views; use --format nerfstudio")
    for name, split in dataset.splits.items():
        d = folder / name
        d.mkdir()
        cams = split.cameras
        frames = [{"transform_matrix": p.tolist()} for p in cams.poses]
        f = (cams if len(cams) else dataset["train"].cameras).focal
        (d / "transforms.json").write_text(json.dumps({"focal": f, "frames": frames}, indent=1))
        K = np.array([[f, 0, 0], [0, f, (cams.height - 1) / 2], [0, 0, 1]])
        depth = (None if split.depth is None                   # -1 on a miss
                 else np.where(np.isfinite(split.depth), split.depth, -1.0).astype(np.float32))
        for i in range(len(split)):
            write_png(d / f"cam-{i}.png", np.concatenate([split.color[i], split.alpha[i][..., None]], -1))
            extra = {k: v[i] for k, v in (("depth_map", depth), ("mask", split.mask), ("rgb_linear", split.linear))
                     if v is not None}
            np.savez(d / f"cam-{i}.npz", intrinsic_mat=K, alpha=split.alpha[i], **extra)
    write_meta(folder, dataset, "nerf2d")


def _column(a: np.ndarray, H: int, what: str, channels: int | None = None) -> np.ndarray:
    """A per-pixel array of an ``H``-pixel view (``H``, ``H x 1`` or ``1 x H``) as ``[H, 1(, channels)]``."""
    c = channels or 1
    if a.size != H * c or a.dtype.kind not in "uifb":
        raise DataError(f"{what} holds {a.shape} {a.dtype} values, expected {H * c} numbers ({c} per pixel); "
                        "regenerate the file")
    return a.reshape((H, 1, c) if channels else (H, 1))


def _read_split(d: Path) -> Split:
    where = str(d / "transforms.json")
    data = read_json(d / "transforms.json")
    frames = get(data, "frames", list, where)
    if not frames:
        raise DataError(f"{d}: the split has no frames; add views or drop the split folder")
    poses = read_poses(frames, 3, where)
    n = len(frames)
    pngs = [d / f"cam-{i}.png" for i in range(n)]
    found = len(list(d.glob("cam-*.png")))
    if found != n or not all(p.exists() for p in pngs):
        raise DataError(f"{d}: transforms.json has {n} poses but the folder has {found} cam-*.png images; "
                        "every frame i needs its cam-i.png")
    h, w = view_size(pngs, str(d))
    if min(h, w) != 1:
        raise DataError(f"{d}: views are {h} x {w} pixels; NeRF2D views are one pixel wide (H x 1)")
    H = max(h, w)
    focal = check_focal(get(data, "focal", (int, float), where), H, where)
    img = np.stack([as_rgba(read_view(p, (h, w))).reshape(H, 1, 4)      # 1 x H or H x 1 images as [H, 1, 4]
                    for p in tqdm(pngs, desc=f"read {d.parent.name}/{d.name}", unit="view", delay=1, leave=False)])
    color, alpha = img[..., :3], img[..., 3]
    depth = mask = linear = None
    npz = [d / f"cam-{i}.npz" for i in range(n)]
    if all_or_none([p.exists() for p in npz], [p.name for p in pngs], str(d), ".npz"):
        files = [read_npz(p) for p in npz]
        for key in ("depth_map", "rgb_linear", "alpha", "mask"):
            all_or_none([key in f for f in files], [p.name for p in npz], str(d), repr(key))
        stack = lambda key, c=None: np.stack([_column(f[key], H, str(p), c) for f, p in zip(files, npz)])
        if "depth_map" in files[0]:                 # each key is in every file or in none (checked above)
            raw = stack("depth_map").astype(np.float32)
            if not np.isfinite(raw).all():
                raise DataError(f"{d}: a depth_map holds NaN or infinity; misses are stored as -1")
            depth = np.where(raw < 0, np.inf, raw).astype(np.float32)
            mask = stack("mask").astype(bool) if "mask" in files[0] else np.isfinite(depth)
        if "rgb_linear" in files[0] and "alpha" in files[0]:
            linear, alpha = stack("rgb_linear", 3).astype(np.float32), stack("alpha").astype(np.float32)
            if linear.shape != (n, H, 1, 3) or not (np.isfinite(linear).all() and np.isfinite(alpha).all()):
                raise DataError(f"{d}: rgb_linear must be finite H x 1 x 3 arrays; regenerate the dataset")
            if alpha.min() < 0 or alpha.max() > 1:
                raise DataError(f"{d}: an npz file's alpha is outside [0, 1]; regenerate the dataset")
            color = display_color(linear, alpha)
    return Split(Cameras(poses, focal, H, 1), color.astype(np.float32), alpha.astype(np.float32), depth, mask, linear)


def read_nerf2d(path: str | Path, downscale: int = 1) -> Dataset:
    """Read a NeRF2D-format folder (ours or the original add-on's), its views ``downscale`` times shorter
    (:meth:`~mitnerf.data.dataset.Split.downscaled`)."""
    path, downscale = Path(path), check_downscale(downscale)
    splits = {s: _read_split(path / s) for s in SPLITS if (path / s / "transforms.json").exists()}
    if "train" not in splits:
        raise DataError(f"{path} has no train/transforms.json; point at a NeRF2D dataset folder")
    meta = read_meta(path, "nerf2d", downscale)
    near, far = meta.get("near"), meta.get("far")
    if near is None or far is None:         # foreign datasets: from the depth maps when present, else from the rig
        depths = [s.depth[np.isfinite(s.depth)] for s in splits.values() if s.depth is not None]
        depths = np.concatenate(depths) if depths else np.zeros(0)
        near, far = ((max(0.05, depths.min() - 0.5), depths.max() + 1.0) if depths.size
                     else bounds_from_cameras([s.cameras for s in splits.values()], 2.0, 0.0))
    return Dataset({s: v.downscaled(downscale) for s, v in splits.items()}, float(near), float(far), meta)
