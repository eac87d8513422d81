"""Pixels as rays (numpy), and the batch schedule both backends share."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..data.dataset import Split


@dataclass
class RaySet:
    """Every pixel of some views as a ray, flat."""

    origins: np.ndarray   # [P, D]
    directions: np.ndarray  # [P, D] unit
    target: np.ndarray    # [P, 3] display-space colour over the background
    depth: np.ndarray     # [P] distance along the ray, 0 where unknown or a miss
    hit: np.ndarray       # [P] 1.0 where the depth is known (the ray hits), else 0.0

    def __len__(self) -> int:
        return len(self.origins)


def rays_of(split: Split, background) -> RaySet:
    o, d = split.cameras.rays()
    D = o.shape[-1]
    target = split.target(background).reshape(-1, 3)
    if split.depth is not None:
        hit = (split.mask if split.mask is not None else np.isfinite(split.depth)).reshape(-1)
        depth = np.where(hit, split.depth.reshape(-1), 0.0)
    else:
        hit, depth = np.zeros(len(target), bool), np.zeros(len(target))
    return RaySet(o.reshape(-1, D).astype(np.float32), d.reshape(-1, D).astype(np.float32),
                  target.astype(np.float32), depth.astype(np.float32), hit.astype(np.float32))


def step_seed(seed: int, step: int) -> int:
    """The 32-bit seed of training step ``step`` (batch choice and sample jitter)."""
    from ..reference.render.samplers import hash_u32

    with np.errstate(over="ignore"):
        return int(hash_u32(np.uint32(seed) * np.uint32(0x01000193) ^ np.uint32(step)))


def batch_indices(seed: int, batch: int, n_pixels: int) -> np.ndarray:
    """The pixels of one batch (numpy twin of the in-kernel choice of the Dr.Jit backend)."""
    from ..reference.render.samplers import hash_u32

    with np.errstate(over="ignore"):
        h = hash_u32(hash_u32(np.uint32(seed)) ^ np.arange(batch, dtype=np.uint32))
    return (h % np.uint32(n_pixels)).astype(np.int64)
