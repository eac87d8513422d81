"""What the readers of real captures share (LLFF, COLMAP, instant-ngp / nerfstudio, IDR): checked intrinsics and
lenses, the held-out test views, frames without images, and views read at a lower resolution.

Every check ends in one :class:`~mitnerf.errors.DataError` line (:mod:`.common`'s rules)."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from ...errors import ConfigError, DataError, MitnerfError, Note
from ..cameras import Cameras
from ..dataset import Dataset, Split, box_downscale, decode, eight_bit
from ..lens import COEFFICIENTS, fold_radius, jacobian, undistort
from .common import as_rgba, check_focal, number, read_meta, read_view, view_size

HOLDOUT = 8
"""Where a capture names no split, image ``i`` is a test view when ``i % 8 == 0`` (NeRF's LLFF protocol) and
a training view otherwise; there is no validation split (the trainer then validates on nothing, never on test)."""
MAX_VIEWS = 100_000
"""Most views a camera file may describe (a larger count is a corrupt header)."""
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")
FORWARD_CONE = 30.0
"""Degrees: a capture whose every view axis lies this close to their mean is forward-facing (``meta['layout']``)."""


def check_downscale(downscale) -> int:
    if isinstance(downscale, bool) or not isinstance(downscale, (int, np.integer)) or downscale < 1:
        raise ConfigError(f"downscale must be a whole number >= 1, got {downscale!r}")
    return int(downscale)


def hold_out(n: int, where: str) -> dict[str, np.ndarray]:
    """Indices of the train and test views of ``n`` images (:data:`HOLDOUT`); at least 2 train and 1 test."""
    index = np.arange(n)
    if n < 3:
        raise DataError(f"{where} has {n} usable image{'s' * (n != 1)}; mitnerf needs at least 3 (2 to train on, "
                        "every 8th held out for test): add images")
    return {"train": index[index % HOLDOUT != 0], "test": index[index % HOLDOUT == 0]}


def check_intrinsics(fx, fy, cx, cy, W: int, H: int, where: str) -> None:
    """Per-frame focal lengths (a field of view in (0.05, 179) degrees along each axis) and a principal point on
    the image (``0 <= cx <= W``, ``0 <= cy <= H``), all ``[n]`` arrays or numbers."""
    for i, (a, b, c, d) in enumerate(np.broadcast(fx, fy, cx, cy)):
        check_focal(a, W, f"{where} (frame {i}, fx)")
        check_focal(b, H, f"{where} (frame {i}, fy)")
        for name, v, size in (("cx", c, W), ("cy", d, H)):
            if not 0 <= number(v, f"{where}: {name}", strict_lo=False) <= size:
                raise DataError(f"{where}: frame {i}'s principal point {name} = {v:g} lies off the image (0 to {size} "
                                "px); check its unit (pixels) and that it belongs to this image size")


def check_lens(cameras: Cameras, where: str) -> None:
    """Refuse a lens that folds over inside the image (two image points, one pixel) or whose formula cannot be
    inverted at the image's edge pixels."""
    if cameras.distortion is None:
        return
    H, W = cameras.height, cameras.width
    unique, first = np.unique(cameras.intrinsics, axis=0, return_index=True)
    for p, i in zip(unique, first):
        fx, fy, cx, cy, k = p[0], p[1], p[2], p[3], p[4:]
        named = ", ".join(f"{n} = {v:g}" for n, v in zip(COEFFICIENTS, k) if v)
        corners = np.array([[(u - cx) / fx, (v - cy) / fy] for u in (0, W) for v in (0, H)])
        r = fold_radius(k)
        reach = r * (1 + r * r * (k[0] + r * r * (k[1] + r * r * k[4]))) if np.isfinite(r) else np.inf
        if np.linalg.norm(corners, axis=1).max() >= reach:
            raise DataError(f"{where}: frame {i}'s lens distortion ({named}) folds over inside the image (beyond "
                            f"{reach:.3g} focal lengths from the principal point); check the coefficients and that "
                            "they belong to these focal lengths")
        u, v = np.arange(W) + 0.5, np.arange(H) + 0.5
        edge = np.concatenate([np.c_[u, np.full(W, 0.5)], np.c_[u, np.full(W, H - 0.5)],
                               np.c_[np.full(H, 0.5), v], np.c_[np.full(H, W - 0.5), v]])
        try:
            J = jacobian(undistort((edge - [cx, cy]) / [fx, fy], k, 1e-9 / max(fx, fy)), k)
        except MitnerfError:
            J = None
        if J is None or not np.all(J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0] > 0):
            raise DataError(f"{where}: frame {i}'s lens distortion ({named}) cannot be inverted at the image's edge; "
                            "check the coefficients and that they belong to these focal lengths")


def image_folder(root: Path, downscale: int, where: str, name: str = "images") -> tuple[Path, int]:
    """The folder of views for ``downscale``: ``images_{downscale}/`` (``images/`` for 1) if it exists, else the
    finest ``images_N/`` (or ``images/``) with ``N`` dividing ``downscale`` (box-filtered by ``downscale / N``);
    with neither, ``downscale`` 1 takes the finest folder there is. Returns ``(folder, N)``."""
    found = {1: root / name} if (root / name).is_dir() else {}
    for p in root.glob(f"{name}_*"):
        m = re.fullmatch(rf"{name}_([1-9][0-9]{{0,3}})", p.name)
        if m and p.is_dir():
            found[int(m.group(1))] = p
    if not found:
        raise DataError(f"{where} has no {name}/ folder (nor {name}_N/); put the photographs in {root / name}")
    fits = [n for n in found if downscale % n == 0] or ([min(found)] if downscale == 1 else [])
    if not fits:
        raise DataError(f"{where}: no image folder fits downscale {downscale} (there are "
                        f"{', '.join(found[n].name + '/' for n in sorted(found))}); choose a multiple of one of them")
    n = max(fits)
    return found[n], n


def absent(paths: list[Path]) -> list[int]:
    """Indices of the frames whose image file does not exist."""
    return [i for i, p in enumerate(paths) if not (p.exists() or p.is_symlink())]


def warn_skipped(where: str, missing: list, total: int) -> None:
    """The one note (:class:`~mitnerf.errors.Note`) that says how many listed frames were skipped for want of
    their image."""
    if missing:
        warnings.warn(f"{where}: {len(missing)} of {total} frames have no image file (the first: {missing[0]}); "
                      "skipped them", Note, stacklevel=2)


def read_views(paths: list[Path], downscale: int, where: str, masks: list[Path] | None = None,
               size: tuple[int, int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Views of one size as ``(colour [n, h, w, 3] premultiplied by alpha, alpha [n, h, w])`` float32, box-filtered
    by ``downscale`` (views one pixel wide, 2D, along their rows only): the image's own alpha, or ``masks`` (grey,
    1 = the object) when given. Where every view's values are 8-bit ones (8-bit files read as they are: a box
    filter or a 16-bit file mostly gives values between them), they come back as :class:`~mitnerf.data.dataset.Split`
    holds them, straight colour and coverage in uint8, made a view at a time: no float copy of the split is whole.
    Sizes and the memory of the result are checked from the headers first (:func:`~.common.view_size`), unless the
    caller did and gives their ``size`` ``(H, W)``."""
    H, W = size or view_size(paths, where, downscale)
    cols = 1 if W == 1 else downscale                  # a 2D view keeps its one column
    h, w = H // downscale, W // cols
    color8, alpha8 = np.empty((len(paths), h, w, 3), np.uint8), np.empty((len(paths), h, w), np.uint8)
    color = alpha = None                                # float32, from the first view that is not 8 bits
    for i, p in enumerate(tqdm(paths, desc=f"read {Path(where).name}", unit="view", delay=1, leave=False)):
        rgba = as_rgba(read_view(p, (H, W)))
        if masks is not None:
            rgba[..., 3] = as_rgba(read_view(masks[i], (H, W), "a mask"))[..., 0]
        rgba[..., :3] *= rgba[..., 3:]
        small = box_downscale(rgba[None], downscale, cols)[0]
        c, a = small[..., :3], small[..., 3]
        q = eight_bit(c, a) if color is None else None
        if q is not None:
            color8[i], alpha8[i] = q
            continue
        if color is None:                               # decode the views before this one, hold floats from here
            color, alpha = np.empty(color8.shape, np.float32), np.empty(alpha8.shape, np.float32)
            color[:i], alpha[:i] = decode(color8[:i], alpha8[:i])
            color8 = alpha8 = None
        color[i], alpha[i] = c, a
    return (color8, alpha8) if color is None else (color, alpha)


def capture_dataset(path: Path, fmt: str, views: Split, split: dict, downscale: int, near_far, **info) -> Dataset:
    """The dataset of a capture's ``views`` cut into ``split`` (indices per split); its meta: mitnerf.json's where there
    is one (its near and far first, else ``near_far()``), with ``format``, ``scene``, ``info`` and the
    ``downscale`` (when > 1)."""
    meta = read_meta(path, fmt, downscale)
    meta.setdefault("scene", path.name)
    meta.update(info)
    near, far = (meta["near"], meta["far"]) if "near" in meta and "far" in meta else near_far()
    return Dataset({s: views.subset(i) for s, i in split.items()}, float(near), float(far), meta)


def layout(poses: np.ndarray) -> str:
    """``"forward"`` when every camera's view axis (OpenGL poses ``[n, 4, 4]``) lies within :data:`FORWARD_CONE`
    of their mean (LLFF's scenes), else ``"around"``."""
    axes = -poses[:, :3, 2]
    mean = axes.sum(0)
    norm = np.linalg.norm(mean)
    return "forward" if norm > 0 and (axes @ mean / norm).min() >= np.cos(np.radians(FORWARD_CONE)) else "around"


def focus_point(poses: np.ndarray) -> np.ndarray:
    """The point nearest to every camera's optical axis (least squares), or the centres' mean where the axes are
    (nearly) parallel."""
    a = -poses[:, :3, 2]
    P = np.eye(3)[None] - a[:, :, None] * a[:, None, :]            # projectors across each axis
    M, v = P.sum(0), np.einsum("nij,nj->i", P, poses[:, :3, 3])
    if np.linalg.cond(M) > 1e6:
        return poses[:, :3, 3].mean(0)
    return np.linalg.solve(M, v)


def near_far(cameras: Cameras, bounds: np.ndarray) -> tuple[float, float]:
    """The distances along any ray that bound per-view depth ``bounds [n, 2]`` (along the optical axis): 0.9 of
    the nearest (as NeRF's LLFF loader) and the farthest stretched along each view's widest ray."""
    return 0.9 * float(bounds[:, 0].min()), float((bounds[:, 1] * cameras.depth_stretch()).max())


def depth_bounds(views: Split, near: float, far: float) -> np.ndarray:
    """``[n, 2]``: each view's nearest and farthest depth along its optical axis of what its depth map hits (of the
    dataset's ``near`` and ``far`` distances for a view without): LLFF's bounds."""
    c = views.cameras
    out = np.c_[near / c.depth_stretch(), np.full(len(c), far)]
    if views.depth is not None:
        z = views.depth * -c.camera_directions()[..., -1]
        for i, (zi, hit) in enumerate(zip(z, np.isfinite(views.depth))):
            if hit.any():
                out[i] = zi[hit].min(), zi[hit].max()
    return out
