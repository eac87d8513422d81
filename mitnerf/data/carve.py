"""How far matter goes on behind each measured depth, as far as every view's depth map allows.

A point on a pixel-centre ray behind the measured depth *D* may be inside the object, or already out of its
back: a thin part (an ear, a wall) is no thicker than it is. Every training view says which points it knows
to be empty, those in front of its own surface (:func:`~mitnerf.data.dataset.free_distance`). The *solid
extent* of a ray is the largest ``s <= reach`` such that no view knows a point of ``[D, D + s]`` to be empty
(tested at ``samples`` points: the extent is the last one before the first carved point), 0 for rays without
a depth and for rays whose first point is already carved (a part thinner than ``reach / samples``). It is space
carving (the visual hull, with depth) along each ray, and it bounds where the solid loss
(:mod:`mitnerf.train.losses`) asks for matter. Cost: rays x samples x views point-in-view tests; beyond
:data:`MAX_TESTS`, an evenly spaced subset of the views carves (at least 8; an extent can only grow), then
fewer samples test each ray (at least 4; coarser steps).
"""

from __future__ import annotations

import numpy as np
from tqdm.auto import tqdm

from .cameras import Cameras

CHUNK = 1 << 21
"""Point-in-view tests at a time (bounds memory: about 90 bytes each)."""
MAX_TESTS = 200_000_000
"""Point-in-view tests above which fewer views, then fewer samples, carve (a bound on memory and time)."""


def pixel_of(cameras: Cameras, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pixel of every camera that sees each world point: ``points [m, D]`` -> ``(row, col, inside)``, each
    ``[n, m]``; ``inside``: the point is in front of the camera and on its image (``row``/``col`` are 0 where not)."""
    H, W = cameras.height, cameras.width
    pixel, fwd = cameras.project(points)            # through each camera's own intrinsics and lens
    with np.errstate(invalid="ignore"):
        row, col = (np.floor(pixel), np.zeros_like(fwd)) if cameras.dim == 2 else np.moveaxis(np.floor(pixel), -1, 0)
        inside = (fwd > 0) & (row >= 0) & (row < H) & (col >= 0) & (col < W)
    return np.where(inside, row, 0).astype(np.int64), np.where(inside, col, 0).astype(np.int64), inside


def carved(cameras: Cameras, free: np.ndarray, points: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """``[m]`` bool: some view knows the point to be empty (nearer to it than its pixel's ``free`` distance,
    ``[n, H, W]``, less ``margin``; ``free`` 0 means unknown)."""
    out = np.zeros(len(points), bool)
    step = max(1, CHUNK // len(cameras))
    for s in range(0, len(points), step):
        p = points[s:s + step]
        row, col, inside = pixel_of(cameras, p)
        bound = free[np.arange(len(cameras))[:, None], row, col]             # [n, m]
        dist = np.linalg.norm(p[None] - cameras.origins[:, None], axis=-1)
        out[s:s + step] = (inside & (bound > 0) & (dist < bound - margin)).any(axis=0)
    return out


def solid_extent(cameras: Cameras, origins: np.ndarray, directions: np.ndarray, depth: np.ndarray, hit: np.ndarray,
                 free: np.ndarray, reach: float, samples: int = 16, margin: float = 0.0) -> np.ndarray:
    """``[n, H, W]`` float32: the solid extent (module docstring) of every pixel-centre ray (``origins``,
    ``directions``: ``[n, H, W, D]``) of ``cameras``, whose measured ``depth`` counts where ``hit``; ``free``: what
    the views know to be empty (their free distances)."""
    n, H, W = depth.shape
    rays = np.flatnonzero(hit.reshape(-1))
    keep = max(8, MAX_TESTS // max(1, len(rays) * samples))
    judges = np.unique(np.linspace(0, n - 1, keep).round().astype(int)) if keep < n else np.arange(n)
    cams, free = cameras.subset(judges), free[judges]
    samples = int(min(samples, max(4, MAX_TESTS // max(1, len(rays) * len(judges)))))
    o, d = (np.asarray(a, np.float32).reshape(-1, cameras.dim)[rays] for a in (origins, directions))
    D = depth.reshape(-1)[rays].astype(np.float32)
    extent = np.full(len(rays), reach, np.float32)
    open_ = np.ones(len(rays), bool)                   # no carved point found yet
    big = len(rays) * samples * len(judges) > MAX_TESTS // 4      # a progress bar past a quarter of the bound
    for k in tqdm(range(1, samples + 1), desc="carving", unit="sample", disable=not big, leave=False):
        idx = np.flatnonzero(open_)
        if not len(idx):
            break
        gone = carved(cams, free, o[idx] + (D[idx] + reach * k / samples)[:, None] * d[idx], margin)
        extent[idx[gone]] = reach * (k - 1) / samples
        open_[idx[gone]] = False
    out = np.zeros(n * H * W, np.float32)
    out[rays] = extent
    return out.reshape(n, H, W)
