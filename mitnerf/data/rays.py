"""Training rays drawn per batch: a batch's rays, colours and what the losses need are computed from the pixels'
``(view, row, col)`` when the batch is drawn, so nothing the size of every training pixel is held beyond the
split's own images (8-bit where they were: :class:`~mitnerf.data.dataset.Split`), its depth maps, and the solid
extents where the solid loss asks for them. Both engines draw the same batches (:func:`mitnerf.rng.batch_indices`).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from ..rng import uniform_np

BACKGROUNDS = {"black": (0.0, 0.0, 0.0), "white": (1.0, 1.0, 1.0)}
"""The named constant backgrounds; ``"random"`` draws a colour per training ray (and evaluates over white)."""
BACKGROUND_SALT = 0x1B873593
"""Seed salt of the random background's colours."""


@dataclass
class RaySet:
    """Rays with what the losses need, flat: a batch (:meth:`TrainingRays.batch`), or every pixel of a split held
    in memory (which serves batches the same way)."""

    origins: np.ndarray     # [P, D]
    directions: np.ndarray  # [P, D] unit, through the pixel centre
    target: np.ndarray      # [P, 3] display-space colour over ``background``
    background: np.ndarray  # [P, 3] the background behind the ray
    depth: np.ndarray       # [P] distance along the ray, 0 where unknown or a miss
    hit: np.ndarray         # [P] 1.0 where the depth is known (the ray hits), else 0.0
    free: np.ndarray        # [P] empty along the ray up to here (:func:`~mitnerf.data.dataset.free_distance`), 0: unknown
    footprint: np.ndarray   # [P, 2, D] the pixel's extent (:meth:`~mitnerf.data.cameras.Cameras.footprint`)
    solid: np.ndarray       # [P] matter behind the depth up to here (:func:`~mitnerf.data.carve.solid_extent`), 0: none

    def __len__(self) -> int:
        return len(self.origins)

    def batch(self, index: np.ndarray, seed: int = 0) -> "RaySet":
        """The rays at ``index`` ``[B]``."""
        return RaySet(*(getattr(self, f.name)[index] for f in fields(self)))


def background_name(background) -> str:
    """``white``, ``black``, ``random`` or ``r,g,b`` (None: the dataset's, unresolved)."""
    if background is None or isinstance(background, str):
        return str(background or "the dataset's")
    return next((k for k, v in BACKGROUNDS.items() if v == tuple(background)), ",".join(f"{v:g}" for v in background))


def background_colors(background, seed: int, n: int) -> np.ndarray:
    """``[n, 3]`` float32: the constant ``(r, g, b)``, or for ``"random"`` a uniform colour per ray drawn from
    ``seed`` (:func:`mitnerf.rng.uniform_np`)."""
    if isinstance(background, str):
        ray = np.arange(n, dtype=np.uint32)
        return np.stack([uniform_np(seed ^ BACKGROUND_SALT, ray, np.full(n, k, np.uint32)) for k in range(3)], 1)
    return np.broadcast_to(np.asarray(background, np.float32), (n, 3))


class TrainingRays:
    """The pixels of a split as training rays over a background, materialised a batch at a time."""

    def __init__(self, split, background, solid: np.ndarray | None = None):
        """``background``: ``(r, g, b)`` or ``"random"``; ``solid``: the split's solid extents ``[n, H, W]``
        (None: no solid loss)."""
        self.split, self.background, self.solid = split, background, solid
        cams = split.cameras
        self.shape = (len(cams), cams.height, cams.width)
        k = cams.dim
        self.group, self.local, self.steps = cams.local_rays()   # [n]; [g, H, W, D]; [g, H, W, 2, D]
        self.rotations = cams.poses[:, :k, :k]
        self.alpha_says = split.has_alpha
        """Whether coverage tells empty pixels (where it does not, free space is unknown)."""
        self.hits = None if split.depth is None else \
            (split.mask if split.mask is not None else np.isfinite(split.depth)).reshape(-1)
        """Flat: the pixels whose depth hits the object (None without depth), found once, not per batch."""

    def __len__(self) -> int:
        return int(np.prod(self.shape))

    def _neighbours(self, view, row, col) -> np.ndarray:
        """Flat indices of each pixel's 3 x 3 neighbourhood, clamped at the border ``[m, 9]``."""
        _, H, W = self.shape
        r = np.clip(row[:, None] + np.array([-1, -1, -1, 0, 0, 0, 1, 1, 1]), 0, H - 1)
        c = np.clip(col[:, None] + np.array([-1, 0, 1, -1, 0, 1, -1, 0, 1]), 0, W - 1)
        return (view[:, None] * H + r) * W + c

    def batch(self, index: np.ndarray, seed: int = 0) -> RaySet:
        """The rays of the pixels at flat indices ``index`` ``[B]`` (into ``[n * H * W]``), the background colours
        of batch ``seed``; the free distance is :func:`~mitnerf.data.dataset.free_distance`'s, from the pixels'
        neighbourhoods."""
        s, (_, H, W) = self.split, self.shape
        view, rest = np.divmod(index, H * W)
        row, col = np.divmod(rest, W)
        R = self.rotations[view]                       # as Cameras.rays() and .footprint(), a batch at a time
        g = self.group[view]
        d = np.einsum("bij,bj->bi", R, self.local[g, row, col])
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        o, fp = s.cameras.origins[view], np.einsum("bij,bsj->bsi", R, self.steps[g, row, col])
        color, alpha = s.pixels(index)
        bg = background_colors(self.background, seed, len(index))
        target = color + (1.0 - alpha[:, None]) * bg
        B = len(index)
        depth, hit, free, solid = (np.zeros(B, np.float32) for _ in range(4))
        if self.hits is not None:
            hits, near = self.hits, self._neighbours(view, row, col)
            hit = hits[index].astype(np.float32)
            depth = np.where(hit > 0, s.depth.reshape(-1)[index], 0.0)
            free = np.where(hits[near], s.depth.reshape(-1)[near], np.inf).min(axis=1)
        elif self.alpha_says:                    # empty all along where the neighbourhood's largest alpha is 0
            free = np.where(s.covered(self._neighbours(view, row, col)).any(axis=1), 0.0, np.inf)
        if self.solid is not None:
            solid = self.solid.reshape(-1)[index]
        f32 = lambda a: np.ascontiguousarray(a, np.float32)
        return RaySet(f32(o), f32(d), f32(target), f32(bg), f32(depth), f32(hit), f32(free), f32(fp), f32(solid))
