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

from ..._io import atomic_write_bytes
from ...errors import MitnerfError
from ..cameras import Cameras
from ..dataset import Dataset, Split


def read_tiny_nerf(path: str | Path, near: float = 2.0, far: float = 6.0) -> Dataset:
    path = Path(path)
    try:
        data = np.load(path)
        images, poses, focal = data["images"], data["poses"], float(data["focal"])
    except (OSError, ValueError) as exc:
        raise MitnerfError(f"cannot read {path} as an .npz file ({exc}); download tiny_nerf_data.npz again") from None
    except KeyError as exc:
        raise MitnerfError(f"{path} lacks {exc}; a tiny-NeRF file has 'images', 'poses' and 'focal'") from None
    if len(images) != len(poses):
        raise MitnerfError(f"{path}: {len(images)} images but {len(poses)} poses; they must match one to one")
    if len(images) < 3:
        raise MitnerfError(f"{path} has {len(images)} frames; need at least 3 (train, val, test)")
    n_train = int(data["n_train"]) if "n_train" in data else min(100, len(images) - 2)
    n_val = int(data["n_val"]) if "n_val" in data else 1
    index = {"train": slice(0, n_train), "val": slice(n_train, n_train + n_val),
             "test": slice(n_train + n_val, None)}
    H, W = images.shape[1:3]
    splits = {}
    for name, sl in index.items():
        cams = Cameras(poses[sl], focal, H, W)
        color = np.clip(images[sl, ..., :3], 0, 1).astype(np.float32)
        splits[name] = Split(cams, color, np.ones(color.shape[:3], np.float32))
    return Dataset(splits, near, far, {"format": "tiny_nerf", "scene": path.stem, "background": [0.0] * 3})


def write_tiny_nerf(dataset: Dataset, path: str | Path) -> Path:
    """Write train + val + test (in that order, composited over the dataset's background)."""
    if dataset.dim != 3:
        raise MitnerfError("tiny-NeRF files hold 3D datasets only")
    order = [dataset[s] for s in ("train", "val", "test")]
    images = np.concatenate([s.target(dataset.background) for s in order]).astype(np.float32)
    poses = np.concatenate([s.cameras.poses for s in order]).astype(np.float32)
    buf = io.BytesIO()
    np.savez(buf, images=images, poses=poses, focal=np.float32(order[0].cameras.focal),
             n_train=len(order[0]), n_val=len(order[1]))
    return atomic_write_bytes(Path(path), buf.getvalue())
