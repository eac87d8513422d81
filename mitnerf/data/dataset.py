"""Datasets in memory: cameras and images per split, plus the scene's bounds.

Colours are kept in display (sRGB) space, premultiplied over black, with coverage ``alpha``
beside them, so any background can be composited later: ``target = color + (1 - alpha) * background``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
from scipy.ndimage import maximum_filter, minimum_filter

from ..errors import MitnerfError
from .cameras import Cameras
from .carve import pixel_of, solid_extent
from .color import display_color
from .packed import Packed
from .rays import TrainingRays

SPLITS = ("train", "val", "test")


def free_distance(depth: np.ndarray | None, mask: np.ndarray | None, alpha: np.ndarray) -> np.ndarray:
    """``[n, H, W]``: how far along each pixel's ray space is known to be empty, for *any* ray through the pixel
    (training rays are jittered across it): the smallest depth of the pixel and its 8 neighbours, ``inf`` where
    none of them hits, and 0 (unknown) where the split has no depth and the alpha does not say (alpha > 0 in
    the neighbourhood, or alpha all ones: a format without it). Without depth, pixels whose neighbourhood has
    alpha 0 are empty all along."""
    if depth is not None:
        hit = mask.astype(bool) if mask is not None else np.isfinite(depth)
        return minimum_filter(np.where(hit, depth, np.inf), size=(1, 3, 3), mode="nearest")
    if np.all(alpha >= 1.0):
        return np.zeros(alpha.shape, np.float32)
    empty = maximum_filter(alpha, size=(1, 3, 3), mode="nearest") <= 0.0     # the neighbourhood's largest alpha is 0
    return np.where(empty, np.inf, 0.0)


def eight_bit(color: np.ndarray, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Straight 8-bit colour and coverage ``(uint8 [..., 3], uint8 [...])`` that :func:`decode` turns back into
    exactly ``color`` (premultiplied, float32) and ``alpha``, or None where they did not come from 8-bit values."""
    a8 = np.rint(alpha * 255.0).clip(0, 255).astype(np.uint8)
    with np.errstate(divide="ignore", invalid="ignore"):
        rgb8 = np.rint(np.where(alpha[..., None] > 0, color / alpha[..., None], 0.0) * 255.0).clip(0, 255)
    rgb8 = rgb8.astype(np.uint8)
    back_c, back_a = decode(rgb8, a8)
    return (rgb8, a8) if np.array_equal(back_c, color) and np.array_equal(back_a, alpha) else None


def decode(rgb8: np.ndarray, a8: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """8-bit straight colour and coverage -> premultiplied display colour and coverage, float32, as an 8-bit image
    file is read (``value / 255``, then colour times coverage)."""
    a = a8.astype(np.float32) / 255.0
    return (rgb8.astype(np.float32) / 255.0) * a[..., None], a


class Split:
    """The views of one split, all arrays ``[n, H, W, ...]``. Colour and coverage read from 8-bit images are held
    as those 8 bits (a quarter of float32's memory) and decoded where they are used: per batch of training rays
    (:meth:`pixels`), per view when evaluating (:meth:`target`). A split that is only rendered against (validation
    and test views) can be held packed (:meth:`packed`): compressed, unpacked a few views at a time."""

    def __init__(self, cameras: Cameras, color: np.ndarray | Packed, alpha: np.ndarray | None,
                 depth: np.ndarray | None = None, mask: np.ndarray | None = None, linear: np.ndarray | None = None):
        """``color``: display-space (sRGB) colour premultiplied by ``alpha`` (over black), float32 ``[n, H, W, 3]``,
        or an 8-bit image's straight colour (uint8, with ``alpha`` uint8 too: held as given), or both packed
        (:class:`~.packed.Packed`, with ``alpha`` None);
        ``alpha``: coverage in [0, 1], ``[n, H, W]`` (all ones when a format has none); ``depth``: distance along
        each pixel-centre ray, ``inf`` on a miss (None: unknown); ``mask``: whether the pixel-centre ray hits the
        object (None: unknown); ``linear``: exact linear RGB over black (datasets rendered here)."""
        self.cameras, self.depth, self.mask, self.linear = cameras, depth, mask, linear
        n, H, W = len(cameras), cameras.height, cameras.width
        if color.shape[0] != n:
            raise MitnerfError(f"{color.shape[0]} images but {n} camera poses; every frame needs exactly one image")
        if color.shape[1:] != (H, W, 3):
            raise MitnerfError(f"images are {color.shape[1:3]} pixels but the cameras expect {(H, W)}; "
                               "fix the resolution in the transforms file")
        for name in ("depth", "mask"):
            arr = getattr(self, name)
            if arr is not None and arr.shape != (n, H, W):
                raise MitnerfError(f"{name} maps have shape {arr.shape[1:]}, expected {(H, W)} for {n} frames")
        if isinstance(color, Packed) != (alpha is None):
            raise MitnerfError("packed views hold their coverage: pass alpha=None with them (and alpha without)")
        if alpha is not None and (color.dtype == np.uint8) != (alpha.dtype == np.uint8):
            raise MitnerfError("8-bit colour needs 8-bit coverage beside it (and float colour float coverage)")
        self._color, self._alpha = color, alpha
        if alpha is not None and color.dtype != np.uint8 and linear is None:    # 8-bit views read as floats: 8 bits
            parts = []
            for c, a in zip(color, alpha):              # up to the first view that is not 8 bits
                if (p := eight_bit(c, a)) is None:
                    break
                parts.append(p)
            else:
                if parts:
                    self._color, self._alpha = np.stack([p[0] for p in parts]), np.stack([p[1] for p in parts])
        self._extents: dict = {}
        """Solid extents already carved, by ``(reach, margin)`` (a fit --auto search fits the split many times)."""

    @property
    def eight_bit(self) -> bool:
        """Whether colour and coverage are held as 8-bit values (packed or not)."""
        return isinstance(self._color, Packed) or self._color.dtype == np.uint8

    @property
    def is_packed(self) -> bool:
        """Whether the views are held packed (:meth:`packed`)."""
        return isinstance(self._color, Packed)

    def _views(self, pick=slice(None)) -> tuple[np.ndarray, np.ndarray]:
        """Colour and coverage of the views ``pick`` as held (8-bit straight, or float32 premultiplied), unpacked."""
        return self._color.take(pick) if self.is_packed else (self._color[pick], self._alpha[pick])

    @property
    def color(self) -> np.ndarray:
        """Display-space (sRGB) colour premultiplied by ``alpha`` (over black), float32, ``[n, H, W, 3]`` (decoded
        for all views at once when held in 8 bits: per batch or per view, use :meth:`pixels` or :meth:`target`)."""
        c, a = self._views()
        return decode(c, a)[0] if self.eight_bit else c

    @property
    def alpha(self) -> np.ndarray:
        """Coverage in [0, 1], float32 ``[n, H, W]``."""
        a = self._views()[1]
        return a.astype(np.float32) / 255.0 if self.eight_bit else a

    @property
    def has_alpha(self) -> bool:
        """Whether coverage tells empty pixels (a format without alpha has it all ones)."""
        if self.is_packed:
            return bool(len(self) and self._color.alpha_min.min() < 255)
        return bool(self._alpha.min() < (255 if self.eight_bit else 1.0))

    def packed(self) -> "Split":
        """This split with its views packed (:class:`~.packed.Packed`: compressed, a fraction of the memory) where
        they are 8-bit ones, else itself. For the splits a fit renders against: :meth:`target` unpacks only the views
        it is asked for and :meth:`subset` keeps the chosen views packed; :meth:`rays` unpacks the split once."""
        if self.is_packed or not self.eight_bit:
            return self
        return Split(self.cameras, Packed.of(self._color, self._alpha), None, self.depth, self.mask, self.linear)

    def unpacked(self) -> "Split":
        """This split with its views held as arrays (8-bit where packed), else itself: what several reads of the
        same views take (one unpacking instead of one per read)."""
        if not self.is_packed:
            return self
        return Split(self.cameras, *self._views(), self.depth, self.mask, self.linear)

    def covered(self, index: np.ndarray) -> np.ndarray:
        """Whether the pixels at flat indices ``index`` have any coverage (alpha > 0); a packed split is unpacked
        whole for it."""
        return self._views()[1].reshape(-1)[index] > 0

    def pixels(self, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Premultiplied colour ``[m, 3]`` and coverage ``[m]`` (float32) of the pixels at flat indices ``index``
        (``[m]`` into ``[n * H * W]``; a packed split is unpacked whole for it)."""
        c, a = self._views()
        c, a = c.reshape(-1, 3)[index], a.reshape(-1)[index]
        return decode(c, a) if self.eight_bit else (c, a)

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
        views = [p._views() for p in parts]
        color, alpha = (np.concatenate([v[k] for v in views]) for k in (0, 1))
        return cls(cams, color, alpha, cat("depth"), cat("mask"), cat("linear"))

    def target(self, background=(0.0, 0.0, 0.0), views=None) -> np.ndarray:
        """Colour composited over ``background`` (display space), ``[n, H, W, 3]``; ``views``: only these."""
        c, a = self._views(slice(None) if views is None else views)
        c, a = decode(c, a) if self.eight_bit else (c, a)
        return c + (1.0 - a[..., None]) * np.asarray(background, np.float32)

    def rays(self, background, solid_reach: float = 0.0, margin: float = 0.0) -> TrainingRays:
        """The split's pixels as training rays over ``background`` (``(r, g, b)`` or ``"random"``), drawn per
        batch; the solid extent behind the depth up to ``solid_reach`` (0: not computed), carved with free-space
        ``margin``."""
        solid = None
        if solid_reach > 0 and self.depth is not None:
            key = (float(solid_reach), float(margin))
            if key not in self._extents:
                o, d = self.cameras.rays()
                hit = self.mask if self.mask is not None else np.isfinite(self.depth)
                self._extents[key] = solid_extent(self.cameras, o, d, self.depth, hit,
                                                  free_distance(self.depth, self.mask, None), solid_reach,
                                                  margin=margin)
            solid = self._extents[key]
        return TrainingRays(self.unpacked(), background, solid)

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
        color, alpha = (self._color.subset(index), None) if self.is_packed else (self._color[index], self._alpha[index])
        return Split(self.cameras.subset(index), color, alpha, pick(self.depth), pick(self.mask), pick(self.linear))


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

    @cached_property
    def bound(self) -> float:
        """Half-extent that normalises positions: 1.1 x the object's radius, from the outline or the unit sphere
        of datasets rendered here (2D / 3D), else (foreign data) the largest coordinate of :attr:`hull_box` where the
        training views' alpha tells empty pixels, else the median camera distance minus ``near``."""
        meta = self.meta
        if "polygon" in meta:
            r = float(np.linalg.norm(np.asarray(meta["polygon"]), axis=1).max())
        elif meta.get("kind") == "3d":
            r = 1.0
        else:
            r = self.camera_radius
            if self.hull_box is not None:
                r = float(np.abs(np.asarray(self.hull_box)).max())
        return 1.1 * r

    @property
    def camera_radius(self) -> float:
        """Foreign data's guess of the object's radius: the median camera distance minus ``near`` (at least 0.5)."""
        cams = np.concatenate([np.linalg.norm(s.cameras.origins, axis=1) for s in self.splits.values()])
        return max(float(np.median(cams)) - self.near, 0.5)

    @cached_property
    def hull_box(self) -> tuple | None:
        """Foreign data whose training views have alpha: the box around those views' visual hull (:func:`hull_box`)
        within ``1.1 x`` the camera radius, as ``(lo_x, lo_y, lo_z, hi_x, hi_y, hi_z)``; None otherwise."""
        train = self.splits.get("train")
        if "polygon" in self.meta or self.meta.get("kind") == "3d" or train is None or not train.has_alpha:
            return None
        return hull_box(train, 1.1 * self.camera_radius)

    @property
    def background(self) -> tuple[float, float, float]:
        return tuple(self.meta.get("background", (0.0, 0.0, 0.0) if self.dim == 2 else (1.0, 1.0, 1.0)))

    def packed(self) -> "Dataset":
        """This dataset with every split but ``train`` packed (:meth:`Split.packed`): what ``mitnerf fit`` holds,
        since it only renders against the validation and test views, a few at a time."""
        return Dataset({k: s if k == "train" else s.packed() for k, s in self.splits.items()}, self.near, self.far,
                       dict(self.meta))

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
HULL_POINTS = 64
"""Points per axis of the lattice whose carving gives a dataset's visual hull (:func:`hull_box`)."""
HULL_VIEWS = 24
"""Training views, evenly spaced, that carve it."""


def hull_box(split: Split, r: float) -> tuple:
    """The box around the points of ``[-r, r]^D`` that no view of ``split`` (at most :data:`HULL_VIEWS` of them)
    knows to be empty: none sees them in a pixel whose neighbourhood has alpha 0 (:func:`free_distance`), and none
    whose border is all empty (the object inside its frame) leaves them out of frame. Found on a lattice of
    :data:`HULL_POINTS` per axis and widened by one lattice step (within ``[-r, r]``): ``(lo..., hi...)``; the whole
    cube when nothing is left (alpha that contradicts the poses)."""
    views = np.unique(np.linspace(0, len(split) - 1, min(len(split), HULL_VIEWS)).round().astype(int))
    sub = split.subset(views)
    D = sub.cameras.dim
    empty = np.isinf(free_distance(None, None, sub.alpha))
    framed = empty[:, [0, -1]].all(axis=(1, 2)) & empty[:, :, [0, -1]].all(axis=(1, 2))     # [n]
    axis = np.linspace(-r, r, HULL_POINTS)
    pts = np.stack(np.meshgrid(*[axis] * D, indexing="ij"), -1).reshape(-1, D)
    lo, hi = np.full(D, np.inf), np.full(D, -np.inf)
    for s in range(0, len(pts), 1 << 15):
        p = pts[s:s + (1 << 15)]
        row, col, inside = pixel_of(sub.cameras, p)                             # [n, m]
        out = (inside & empty[np.arange(len(views))[:, None], row, col] | ~inside & framed[:, None]).any(0)
        if not out.all():
            lo, hi = np.minimum(lo, p[~out].min(0)), np.maximum(hi, p[~out].max(0))
    if not np.isfinite(lo).all():
        return (-r,) * D + (r,) * D
    step = 2 * r / (HULL_POINTS - 1)
    return tuple(round(float(v), 4) for v in np.concatenate([np.clip(lo - step, -r, r), np.clip(hi + step, -r, r)]))


def bounds_from_cameras(cams: list[Cameras], radius: float, margin: float = 0.1) -> tuple[float, float]:
    """Near/far for an object inside a sphere of ``radius`` at the origin."""
    dist = np.concatenate([np.linalg.norm(c.origins, axis=1) for c in cams if len(c)])
    return float(max(0.05, dist.min() - radius - margin)), float(dist.max() + radius + margin)
