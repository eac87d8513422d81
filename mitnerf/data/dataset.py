"""Datasets in memory: cameras and images per split, plus the scene's bounds.

Colours are kept in display (sRGB) space, premultiplied over black, with coverage ``alpha``
beside them, so any background can be composited later: ``target = color + (1 - alpha) * background``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import MitnerfError
from .cameras import Cameras
from .carve import solid_extent
from .color import display_color

SPLITS = ("train", "val", "test")


@dataclass
class RaySet:
    """Every pixel of some views as a ray, flat (what training draws its batches from)."""

    origins: np.ndarray     # [P, D]
    directions: np.ndarray  # [P, D] unit
    target: np.ndarray      # [P, 3] display-space colour over the background
    depth: np.ndarray       # [P] distance along the ray, 0 where unknown or a miss
    hit: np.ndarray         # [P] 1.0 where the depth is known (the ray hits), else 0.0
    free: np.ndarray        # [P] empty along the ray up to here (:func:`free_distance`), 0 where unknown
    footprint: np.ndarray   # [P, 2, D] the pixel's extent (:meth:`Cameras.footprint`)
    solid: np.ndarray       # [P] matter behind the depth up to here (:func:`~mitnerf.data.carve.solid_extent`), 0: none

    def __len__(self) -> int:
        return len(self.origins)


def free_distance(depth: np.ndarray | None, mask: np.ndarray | None, alpha: np.ndarray) -> np.ndarray:
    """``[n, H, W]``: how far along each pixel's ray space is known to be empty, for *any* ray through the pixel
    (training rays are jittered across it): the smallest depth of the pixel and its 8 neighbours, ``inf`` where
    none of them hits, and 0 (unknown) where the split has no depth and the alpha does not say (alpha > 0 in
    the neighbourhood, or alpha all ones: a format without it). Without depth, pixels whose neighbourhood has
    alpha 0 are empty all along."""
    def neighbourhood_min(a: np.ndarray) -> np.ndarray:
        out = a.copy()
        for axis in (1, 2):
            if a.shape[axis] > 1:
                p = np.moveaxis(out, axis, 0)
                m = p.copy()
                m[1:] = np.minimum(m[1:], p[:-1])
                m[:-1] = np.minimum(m[:-1], p[1:])
                out = np.moveaxis(m, 0, axis)
        return out

    if depth is not None:
        hit = mask.astype(bool) if mask is not None else np.isfinite(depth)
        return neighbourhood_min(np.where(hit, depth, np.inf))
    if np.all(alpha >= 1.0):
        return np.zeros(alpha.shape, np.float32)
    empty = -neighbourhood_min(-alpha) <= 0.0          # the neighbourhood's largest alpha is 0
    return np.where(empty, np.inf, 0.0)


@dataclass
class Split:
    """The views of one split, all arrays ``[n, H, W, ...]``."""

    cameras: Cameras
    color: np.ndarray
    """Display-space (sRGB) colour premultiplied by ``alpha`` (over black), float32, ``[n, H, W, 3]``."""
    alpha: np.ndarray
    """Coverage in [0, 1], ``[n, H, W]`` (all ones when a format has no alpha)."""
    depth: np.ndarray | None = None
    """Distance along each pixel-centre ray, ``inf`` on a miss; ``None`` when unknown."""
    mask: np.ndarray | None = None
    """Whether the pixel-centre ray hits the object; ``None`` when unknown."""
    linear: np.ndarray | None = None
    """Exact linear RGB over black (datasets rendered here), ``[n, H, W, 3]``."""
    _extents: dict = field(default_factory=dict, init=False, repr=False, compare=False)
    """Solid extents already carved, by ``(reach, margin)`` (a fit --auto search fits the split many times)."""

    def __post_init__(self):
        n, H, W = len(self.cameras), self.cameras.height, self.cameras.width
        if self.color.shape[0] != n:
            raise MitnerfError(f"{self.color.shape[0]} images but {n} camera poses; "
                               "every frame needs exactly one image")
        if self.color.shape[1:] != (H, W, 3):
            raise MitnerfError(f"images are {self.color.shape[1:3]} pixels but the cameras expect {(H, W)}; "
                               "fix the resolution in the transforms file")
        for name in ("depth", "mask"):
            arr = getattr(self, name)
            if arr is not None and arr.shape != (n, H, W):
                raise MitnerfError(f"{name} maps have shape {arr.shape[1:]}, expected {(H, W)} for {n} frames")

    @classmethod
    def from_linear(cls, cameras: Cameras, linear, alpha, depth=None, mask=None) -> "Split":
        return cls(cameras, display_color(linear, alpha), alpha.astype(np.float32), depth, mask,
                   linear.astype(np.float32))

    def __len__(self) -> int:
        return len(self.cameras)

    @classmethod
    def concatenate(cls, parts: list["Split"]) -> "Split":
        """The views of several splits of one camera model, in order."""
        if len(parts) == 1:
            return parts[0]
        cat = lambda name: (None if getattr(parts[0], name) is None
                            else np.concatenate([getattr(p, name) for p in parts]))
        cams = Cameras.concatenate([p.cameras for p in parts])
        return cls(cams, cat("color"), cat("alpha"), cat("depth"), cat("mask"), cat("linear"))

    def target(self, background=(0.0, 0.0, 0.0)) -> np.ndarray:
        """Colour composited over ``background`` (display space), ``[n, H, W, 3]``."""
        bg = np.asarray(background, np.float32)
        return self.color + (1.0 - self.alpha[..., None]) * bg

    def rays(self, background, solid_reach: float = 0.0, margin: float = 0.0) -> RaySet:
        """Every pixel of the split as a ray, with its colour over ``background`` and its depth; the solid extent
        behind the depth up to ``solid_reach`` (0: not computed), carved with free-space ``margin``."""
        o, d = self.cameras.rays()
        D = o.shape[-1]
        target = self.target(background).reshape(-1, 3)
        if self.depth is not None:
            hit = (self.mask if self.mask is not None else np.isfinite(self.depth)).reshape(-1)
            depth = np.where(hit, self.depth.reshape(-1), 0.0)
        else:
            hit, depth = np.zeros(len(target), bool), np.zeros(len(target))
        free = free_distance(self.depth, self.mask, self.alpha)
        solid = np.zeros(hit.shape)
        if solid_reach > 0 and self.depth is not None:
            key = (float(solid_reach), float(margin))
            if key not in self._extents:
                self._extents[key] = solid_extent(self.cameras, o, d, self.depth, hit.reshape(self.depth.shape),
                                                  free, solid_reach, margin=margin)
            solid = self._extents[key]
        flat = lambda a, *shape: np.asarray(a, np.float32).reshape(-1, *shape)
        return RaySet(flat(o, D), flat(d, D), flat(target, 3), flat(depth), flat(hit), flat(free),
                      flat(self.cameras.footprint(), 2, D), flat(solid))

    def downscaled(self, factor: int) -> "Split":
        """The views box-filtered by ``factor`` (:func:`box_downscale`; 2D views along their rows): colour, alpha
        and linear colour averaged, a mask where most of a block hits; depth maps left out (a block of pixels has
        no one depth along its centre ray)."""
        if factor == 1:
            return self
        box = lambda a: None if a is None else box_downscale(a, factor, 1 if self.cameras.dim == 2 else factor)
        alpha, linear = box(self.alpha), box(self.linear)
        color = box(self.color) if linear is None else display_color(linear, alpha)
        mask = None if self.mask is None else box(self.mask.astype(np.float32)) > 0.5
        return Split(self.cameras.downscaled(factor), color, alpha, None, mask, linear)

    def subset(self, index) -> "Split":
        pick = lambda a: None if a is None else a[index]
        return Split(self.cameras.subset(index), self.color[index], self.alpha[index],
                     pick(self.depth), pick(self.mask), pick(self.linear))


@dataclass
class Dataset:
    """Splits ``train``/``val``/``test`` and what a renderer needs to know about them."""

    splits: dict[str, Split]
    near: float
    """Smallest distance along any ray at which the object can start."""
    far: float
    """Largest distance along any ray at which the object can end."""
    meta: dict = field(default_factory=dict)
    """Provenance: scene, rig and render settings, source format, default background."""

    def __getitem__(self, split: str) -> Split:
        if split not in self.splits:
            raise MitnerfError(f"dataset has no {split!r} split (it has {', '.join(self.splits)})")
        return self.splits[split]

    @property
    def dim(self) -> int:
        return next(iter(self.splits.values())).cameras.dim

    @property
    def name(self) -> str:
        """What figures and output folders call the data: its scene, else its file or folder's name."""
        return self.meta.get("scene") or (Path(self.meta["path"]).stem if self.meta.get("path") else "data")

    @property
    def bound(self) -> float:
        """Half-extent that normalises positions: 1.1 x the object's radius, from the outline or the unit sphere
        of datasets rendered here (2D / 3D), else the median camera distance minus ``near`` (foreign data)."""
        meta = self.meta
        if "polygon" in meta:
            r = float(np.linalg.norm(np.asarray(meta["polygon"]), axis=1).max())
        elif meta.get("kind") == "3d":
            r = 1.0
        else:
            cams = np.concatenate([np.linalg.norm(s.cameras.origins, axis=1) for s in self.splits.values()])
            r = max(float(np.median(cams)) - self.near, 0.5)
        return 1.1 * r

    @property
    def background(self) -> tuple[float, float, float]:
        return tuple(self.meta.get("background", (0.0, 0.0, 0.0) if self.dim == 2 else (1.0, 1.0, 1.0)))

    def sparse(self, train_index=None) -> "Dataset":
        """The training views ``train_index`` (all if None) and the test split, no validation split (so the
        trainer never stops a few-view run for looking collapsed; NaN still stops it)."""
        train = self["train"] if train_index is None else self["train"].subset(train_index)
        return Dataset({"train": train, "test": self["test"]}, self.near, self.far, dict(self.meta))


def box_downscale(a: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """``[n, H, W, ...]`` averaged over blocks of ``rows x cols`` pixels (the remainder cropped at the bottom and
    right, so pixel corners stay where :meth:`~mitnerf.data.cameras.Cameras.downscaled` puts them)."""
    if rows == cols == 1:
        return a
    n, H, W = a.shape[:3]
    h, w = H // rows, W // cols
    return a[:, :h * rows, :w * cols].reshape(n, h, rows, w, cols, *a.shape[3:]).mean(axis=(2, 4)).astype(a.dtype)


def bounds_from_cameras(cams: list[Cameras], radius: float, margin: float = 0.1) -> tuple[float, float]:
    """Near/far for an object inside a sphere of ``radius`` at the origin."""
    dist = np.concatenate([np.linalg.norm(c.origins, axis=1) for c in cams if len(c)])
    return float(max(0.05, dist.min() - radius - margin)), float(dist.max() + radius + margin)
