"""The classic ``tiny_nerf_data.npz``: ``images [N, H, W, 3]`` (sRGB floats), ``poses
[N, 4, 4]`` (OpenGL cameras), ``focal`` (pixels).

Splits follow the tiny-NeRF notebook: the first ``min(100, N - 2)`` frames train,
the next one validates, the rest test (frame 101, the notebook's test view, among
them); files written here add ``n_train`` and ``n_val`` keys, which take precedence.
The file carries no depth or alpha; near and far default to 2 and 6.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ...errors import DataError
from ..cameras import Cameras
from ..dataset import Dataset, Split
from .common import MAX_SIDE, check_focal, check_memory, check_poses, integer, npz_shapes, read_npz


def read_tiny_nerf(path: str | Path, near: float = 2.0, far: float = 6.0) -> Dataset:
    path = Path(path)
    shape = npz_shapes(path).get("images", ((),))[0]
    if len(shape) == 4:                 # refuse huge images from the header, before loading them
        n, H, W = shape[:3]
        if max(H, W) > MAX_SIDE:
            raise DataError(f"{path}: views of {H} x {W} pixels are too large (at most {MAX_SIDE} per side); "
                            "downsample them")
        check_memory(n * H * W, str(path))
    data = read_npz(path)
    missing = [k for k in ("images", "poses", "focal") if k not in data]
    if missing:
        raise DataError(f"{path} lacks {', '.join(missing)}; a tiny-NeRF file has 'images', 'poses' and 'focal'")
    images, poses, focal = data["images"], data["poses"], data["focal"]
    if images.ndim != 4 or images.shape[-1] not in (3, 4) or images.dtype.kind not in "uif":
        raise DataError(f"{path}: 'images' must be [N, H, W, 3] numbers, got {images.shape} {images.dtype}")
    if poses.shape != (len(images), 4, 4) or poses.dtype.kind not in "if":
        raise DataError(f"{path}: {len(images)} images need 'poses' of shape [{len(images)}, 4, 4], got {poses.shape}")
    if focal.size != 1 or focal.dtype.kind not in "if":
        raise DataError(f"{path}: 'focal' must be one number (pixels), got {focal.shape} {focal.dtype}")
    n, H, W = images.shape[:3]
    if max(H, W) > MAX_SIDE:
        raise DataError(f"{path}: views of {H} x {W} pixels are too large; downsample them")
    if n < 3:
        raise DataError(f"{path} has {n} frames; need at least 3 (train, val, test)")
    check_memory(n * H * W, str(path))
    check_poses(poses.astype(np.float64), str(path))
    focal = check_focal(float(focal.reshape(-1)[0]), W, str(path))
    n_train = integer(_one(data["n_train"], path, "n_train"), f"{path}: n_train", 1, n - 1) if "n_train" in data \
        else min(100, n - 2)
    n_val = integer(_one(data["n_val"], path, "n_val"), f"{path}: n_val", 0, n - n_train - 1) if "n_val" in data \
        else 1
    img = images[..., :3].astype(np.float32) / (255.0 if images.dtype == np.uint8 else 1.0)
    if not np.isfinite(img).all():
        raise DataError(f"{path}: 'images' contains NaN or infinity; replace the file")
    index = {"train": slice(0, n_train), "val": slice(n_train, n_train + n_val), "test": slice(n_train + n_val, None)}
    splits = {}
    for name, sl in index.items():
        color = np.clip(img[sl], 0, 1)
        splits[name] = Split(Cameras(poses[sl], focal, H, W), color, np.ones(color.shape[:3], np.float32))
    return Dataset(splits, near, far, {"format": "tiny_nerf", "scene": path.stem, "background": [0.0] * 3})


def _one(a: np.ndarray, path: Path, key: str):
    if a.size != 1:
        raise DataError(f"{path}: {key!r} must be one number, got an array of shape {a.shape}; fix the file")
    return a.reshape(-1)[0]


def tiny_nerf_bytes(dataset: Dataset) -> bytes:
    """The file of train + val + test (in that order, composited over the dataset's background)."""
    if dataset.dim != 3:
        raise DataError("tiny-NeRF files hold 3D datasets only")
    order = [dataset[s] for s in ("train", "val", "test")]
    images = np.concatenate([s.target(dataset.background) for s in order]).astype(np.float32)
    poses = np.concatenate([s.cameras.poses for s in order]).astype(np.float32)
    buf = io.BytesIO()
    np.savez(buf, images=images, poses=poses, focal=np.float32(order[0].cameras.focal),
             n_train=len(order[0]), n_val=len(order[1]))
    return buf.getvalue()
