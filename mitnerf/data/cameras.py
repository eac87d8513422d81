"""Pinhole cameras and their pixel-centre rays, in numpy.

Conventions (the same as the file formats, so rays never need converting):

* **2D (NeRF2D)**: a pose is a 3x3 camera-to-world matrix in homogeneous 2D coordinates: column 0 is the
  viewing direction, column 1 the camera's "up" (towards pixel row 0), column 2 the position. Pixel row ``i``
  of an ``H``-pixel view looks along ``normalize([f, cy - (i + 0.5)])`` in camera space (``cy = H/2`` unless
  given).
* **3D (Blender / nerfstudio / OpenGL)**: a pose is a 4x4 camera-to-world matrix; the camera looks down -z
  with +y up and +x right. Pixel ``(row v, column u)`` shows the normalised point
  ``(x_d, y_d) = ((u + 0.5 - cx) / fx, (v + 0.5 - cy) / fy)`` (the image's top-left corner is ``(0, 0)``, as
  in COLMAP and nerfstudio); the lens (:mod:`.lens`) maps it back to ``(x, y)``, and the pixel looks along
  ``normalize([x, -y, -1])``. Without distortion and with ``cx = W/2``, ``cy = H/2``, ``fx = fy = f`` this is
  ``normalize([(u + 0.5 - W/2) / f, -(v + 0.5 - H/2) / f, -1])``.

Intrinsics are per frame (arrays ``[n]``); frames that share them share the work of undistorting. Directions
are unit length, so a depth is the distance along the pixel-centre ray. Images are ``[n, H, W, ...]``; a 2D
view is ``H`` pixels tall and one pixel wide.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._io import available_memory
from ..errors import ConfigError, MitnerfError
from .lens import distort, fold_radius, jacobian, undistort

PIXEL_BYTES = 32
"""The least memory a pixel of a set of views costs once rendered (colour, alpha, depth, mask)."""
UNDISTORT_TOL = 1e-9
"""Pixels: how closely an undistorted pixel-centre ray reproduces its pixel through the lens."""


def check_pixel_memory(n: int, H: int, W: int) -> None:
    """Refuse up front ``n`` views of ``H x W`` whose pixels cannot fit in memory (``--views`` or ``--frames`` x
    ``--resolution``)."""
    need = n * H * W * PIXEL_BYTES
    avail = available_memory() if need >= 1 << 30 else None
    if avail is not None and need > avail:
        raise ConfigError(f"{n:,} views of {W} x {H} pixels ({n * H * W:,} pixels) need at least "
                          f"{need / 2**30:.1f} GiB; this machine has {avail / 2**30:.1f} GiB available: use fewer "
                          "views (or frames) or a lower resolution")


@dataclass
class Cameras:
    """A set of pinhole cameras of one resolution, each with its own intrinsics and (3D) lens distortion."""

    poses: np.ndarray
    """``[n, 3, 3]`` (2D) or ``[n, 4, 4]`` (3D) camera-to-world matrices."""
    fx: np.ndarray
    """Horizontal focal length in pixels (2D: the only one, along the view), a number or ``[n]``."""
    height: int
    """Pixel rows (in 2D the length of the 1D image)."""
    width: int = 1
    """Pixel columns (1 in 2D)."""
    fy: np.ndarray | None = None
    """Vertical focal length in pixels (3D), a number or ``[n]``; None: ``fx`` (square pixels; 2D: always)."""
    cx: np.ndarray | None = None
    """Principal point's column in pixels from the image's left edge, a number or ``[n]``; None: ``width / 2``."""
    cy: np.ndarray | None = None
    """Principal point's row in pixels from the image's top edge (2D: along the view), a number or ``[n]``;
    None: ``height / 2``."""
    distortion: np.ndarray | None = None
    """Lens coefficients ``(k1, k2, p1, p2, k3)`` (:mod:`.lens`), ``[5]`` or ``[n, 5]`` (3D only); None or all
    zero: none (stored as None)."""

    def __post_init__(self):
        self.poses = np.asarray(self.poses, dtype=np.float64)
        if self.poses.ndim != 3 or self.poses.shape[1:] not in ((3, 3), (4, 4)):
            raise MitnerfError(f"poses must be [n, 3, 3] (2D) or [n, 4, 4] (3D), got {self.poses.shape}")
        bad = np.flatnonzero(~np.isfinite(self.poses).all(axis=(1, 2)))
        if len(bad):
            raise MitnerfError(f"pose {bad[0]} contains NaN or infinity; fix or drop that frame")
        if self.height < 1 or self.width < 1:
            raise MitnerfError(f"resolution must be at least 1 pixel, got {self.height}x{self.width}")
        if self.dim == 2 and self.width != 1:
            raise MitnerfError("2D cameras see 1D images: width must be 1")
        n = len(self.poses)
        per_frame = lambda v, default: np.array(np.broadcast_to(np.asarray(default if v is None else v, np.float64),
                                                                (n,)))
        self.fx = per_frame(self.fx, None)
        self.fy, self.cx, self.cy = (per_frame(self.fy, self.fx), per_frame(self.cx, self.width / 2),
                                     per_frame(self.cy, self.height / 2))
        for name in ("fx", "fy"):
            v = getattr(self, name)
            if not (np.isfinite(v) & (v > 0)).all():
                raise MitnerfError(f"focal length {name} must be a positive number of pixels, got {v[~(v > 0)][:1]}")
        if not (np.isfinite(self.cx).all() and np.isfinite(self.cy).all()):
            raise MitnerfError("the principal point (cx, cy) must be finite numbers of pixels")
        if self.dim == 2 and np.any(self.fy != self.fx):
            raise MitnerfError("2D cameras have one focal length: fy must equal fx")
        if self.distortion is not None:
            k = np.array(np.broadcast_to(np.asarray(self.distortion, np.float64), (n, 5)))
            if not np.isfinite(k).all():
                raise MitnerfError("lens distortion coefficients must be finite numbers")
            if self.dim == 2 and k.any():
                raise MitnerfError("2D cameras have no lens distortion")
            self.distortion = k if k.any() else None
        check_pixel_memory(n, self.height, self.width)

    @property
    def dim(self) -> int:
        return 2 if self.poses.shape[-1] == 3 else 3

    def __len__(self) -> int:
        return len(self.poses)

    @property
    def origins(self) -> np.ndarray:
        """Camera positions, ``[n, dim]``."""
        return self.poses[:, : self.dim, self.dim]

    @property
    def intrinsics(self) -> np.ndarray:
        """``[n, 9]``: ``fx, fy, cx, cy, k1, k2, p1, p2, k3`` of every frame."""
        k = np.zeros((len(self), 5)) if self.distortion is None else self.distortion
        return np.c_[self.fx, self.fy, self.cx, self.cy, k]

    @property
    def simple(self) -> bool:
        """One focal length shared by every frame, square pixels, the principal point at the image's centre and
        no lens distortion (what the NeRF2D and tiny-NeRF formats and Mitsuba's sensors can hold)."""
        return bool(self.distortion is None and np.all(self.fx == self.fx[:1]) and np.all(self.fy == self.fx)
                    and np.all(self.cx == self.width / 2) and np.all(self.cy == self.height / 2))

    @property
    def focal(self) -> float:
        """The one focal length of :attr:`simple` cameras (code that handles any camera reads ``fx`` ...)."""
        if not len(self):
            raise MitnerfError("an empty set of cameras has no focal length")
        if not self.simple:
            raise MitnerfError("these cameras have per-frame intrinsics, an off-centre principal point or lens "
                               "distortion; this use needs one focal length (convert the dataset to pinhole views)")
        return float(self.fx[0])

    @property
    def fov(self) -> float:
        """Field of view in degrees along the image length (2D) or width (3D), of :attr:`simple` cameras."""
        n = self.height if self.dim == 2 else self.width
        return float(np.degrees(2 * np.arctan(n / (2 * self.focal))))

    def subset(self, index) -> "Cameras":
        pick = lambda a: None if a is None else a[index]
        return Cameras(self.poses[index], self.fx[index], self.height, self.width, self.fy[index], self.cx[index],
                       self.cy[index], pick(self.distortion))

    @classmethod
    def concatenate(cls, parts: list["Cameras"]) -> "Cameras":
        """The frames of several sets of one resolution, in order."""
        c0 = parts[0]
        if any((c.height, c.width) != (c0.height, c0.width) for c in parts):
            raise MitnerfError("cameras of different resolutions cannot be joined")
        cat = lambda name: np.concatenate([getattr(c, name) for c in parts])
        lens = None if all(c.distortion is None for c in parts) else np.concatenate(
            [np.zeros((len(c), 5)) if c.distortion is None else c.distortion for c in parts])
        return cls(cat("poses"), cat("fx"), c0.height, c0.width, cat("fy"), cat("cx"), cat("cy"), lens)

    def downscaled(self, factor: int) -> "Cameras":
        """The cameras of images box-filtered by ``factor`` (the remainder rows and columns cropped at the bottom
        and right): intrinsics divided by ``factor`` (pixel corners stay corners); 2D views keep one column."""
        s, W = float(factor), (self.width if self.dim == 2 else self.width // factor)
        return Cameras(self.poses, self.fx / s, self.height // factor, W, self.fy / s,
                       self.cx if self.dim == 2 else self.cx / s, self.cy / s, self.distortion)

    def _groups(self) -> tuple[np.ndarray, np.ndarray]:
        """Frames that share intrinsics: ``(unique [g, 9], inverse [n])``."""
        unique, inverse = np.unique(self.intrinsics, axis=0, return_inverse=True)
        return unique, inverse.reshape(-1)

    def _directions(self, p: np.ndarray, steps: bool = False):
        """For intrinsics ``p [9]``: pixel-centre directions in camera space, not normalised, ``[H, W, dim]``; with
        ``steps``, also each pixel's extent (:meth:`footprint`) as steps of the raw direction, ``[H, W, 2, dim]``."""
        H, W = self.height, self.width
        fx, fy, cx, cy, k = p[0], p[1], p[2], p[3], p[4:]
        if self.dim == 2:
            raw = np.stack([np.full(H, fx), cy - (np.arange(H) + 0.5)], -1)[:, None, :]
            return (raw, np.broadcast_to([[0.0, -1.0], [0.0, 0.0]], (H, 1, 2, 2))) if steps else raw
        X, Y = np.meshgrid((np.arange(W) + 0.5 - cx) / fx, (np.arange(H) + 0.5 - cy) / fy)
        xy = np.stack([X, Y], -1)
        if k.any():
            xy = undistort(xy, k, UNDISTORT_TOL / max(fx, fy))
        raw = np.stack([xy[..., 0], -xy[..., 1], -np.ones_like(X)], -1)
        if not steps:
            return raw
        J = np.linalg.inv(jacobian(xy, k)) if k.any() else np.eye(2)   # d(x, y) / d(x_d, y_d)
        d = np.broadcast_to(J, (H, W, 2, 2)) * np.array([1 / fx, 1 / fy])     # [H, W, (x, y), (column, row)]
        s = np.zeros((H, W, 2, 3))                                            # [H, W, (column, row), xyz]
        s[..., 0], s[..., 1] = d[..., 0, :], -d[..., 1, :]
        return raw, s

    def camera_directions(self, index=None) -> np.ndarray:
        """Unit pixel-centre directions in camera space of the frames ``index`` (all if None), ``[n, H, W, dim]``."""
        group, local, _ = self.local_rays(steps=False)
        return local[group if index is None else group[index]]

    def local_rays(self, steps: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Camera-space rays per group of frames that share intrinsics: ``(group of each frame [n], unit pixel-centre
        directions [g, H, W, dim], each pixel's extent as steps of them [g, H, W, 2, dim])`` (:meth:`footprint`
        before the rotation); without ``steps``, None for the extent (a third of the work)."""
        unique, inverse = self._groups()
        parts = [self._directions(p, steps=True) if steps else (self._directions(p), None) for p in unique]
        norm = [np.linalg.norm(raw, axis=-1, keepdims=True) for raw, _ in parts]
        shape = (len(parts), self.height, self.width, self.dim)          # no frames: no groups
        stack = lambda arrays, shape: np.stack(arrays) if arrays else np.zeros(shape)
        local = stack([raw / n for (raw, _), n in zip(parts, norm)], shape)
        extent = stack([s / n[..., None] for (_, s), n in zip(parts, norm)], (*shape[:3], 2, self.dim)) if steps \
            else None
        return inverse, local, extent

    def depth_stretch(self) -> np.ndarray:
        """``[n]``: the largest distance along a pixel-centre ray per unit of depth along the optical axis (3D: the
        view axis), over each frame's pixels (>= 1: a depth bound times it bounds the distance)."""
        unique, inverse = self._groups()
        axis = 0 if self.dim == 2 else -1
        raws = [self._directions(p) for p in unique]
        widest = [(np.linalg.norm(raw, axis=-1) / np.abs(raw[..., axis])).max() for raw in raws]
        return np.array(widest)[inverse]

    def footprint(self) -> np.ndarray:
        """Each pixel's extent as steps of its unit direction, ``[n, H, W, 2, dim]``: the ray through the point
        ``(a, b)`` of pixel ``(v, u)`` (``a, b`` in [-1/2, 1/2], 0 at the centre) has the direction
        ``normalize(d + a s_0 + b s_1)`` (to first order through the lens). In 2D ``s_0`` steps one row and ``s_1``
        is zero (1D views)."""
        group, _, steps = self.local_rays()
        k = self.dim
        return np.einsum("nij,nhwsj->nhwsi", self.poses[:, :k, :k], steps[group])

    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        """Origins and unit directions of every pixel-centre ray, each ``[n, H, W, dim]``."""
        group, local, _ = self.local_rays(steps=False)
        k = self.dim
        d = np.matmul(local[group], np.swapaxes(self.poses[:, None, :k, :k], -1, -2))       # R d, frame by frame
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        return np.ascontiguousarray(np.broadcast_to(self.origins[:, None, None, :], d.shape)), d

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """World points ``[m, dim]`` in every camera's axes, ``[n, m, dim]`` (through the inverse of each pose's
        rotation, so a pose read with rounding errors still maps its own rays back)."""
        k = self.dim
        return np.einsum("nij,nmj->nmi", np.linalg.inv(self.poses[:, :k, :k]), points[None] - self.origins[:, None])

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Continuous pixel coordinates of world points ``[m, dim]`` in every camera, through the lens:
        ``(pixel, forward)``; ``pixel`` is the row ``[n, m]`` in 2D and ``(row, column)`` ``[n, m, 2]`` in 3D.
        Pixel ``floor(row)`` (and ``floor(column)``) sees the point (the centre ray of pixel ``i`` has
        ``row == i + 0.5``); ``forward`` is the camera-space distance along the view axis (> 0 in front). Points
        behind a camera, or beyond its lens's :func:`~mitnerf.data.lens.fold_radius`, give NaN."""
        cam = self.to_camera(points)                          # [n, m, dim]
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.dim == 2:
                fwd = cam[..., 0]
                return np.where(fwd > 0, self.cy[:, None] - self.fx[:, None] * cam[..., 1] / fwd, np.nan), fwd
            fwd = -cam[..., 2]
            xy = np.where((fwd > 0)[..., None], np.stack([cam[..., 0], -cam[..., 1]], -1) / fwd[..., None], np.nan)
        if self.distortion is not None:
            k = self.distortion[:, None, :]
            reach = np.array([fold_radius(c) for c in self.distortion])[:, None]
            xy = np.where((np.linalg.norm(xy, axis=-1) < reach)[..., None], distort(xy, k), np.nan)
        row = self.fy[:, None] * xy[..., 1] + self.cy[:, None]
        col = self.fx[:, None] * xy[..., 0] + self.cx[:, None]
        return np.stack([row, col], -1), fwd

    def mitsuba_frames(self) -> np.ndarray:
        """``to_world`` matrices of Mitsuba ``perspective`` sensors, ``[n, 4, 4]`` (Mitsuba looks down +z, +x to
        the image's left, +y up). In 2D the film is ``H x 1`` (film column ``i`` is pixel row ``i``); 3D: ``W x H``."""
        if self.dim == 3:
            return self.poses @ np.diag([-1.0, 1.0, -1.0, 1.0])
        n = len(self)
        M = np.zeros((n, 4, 4))
        fwd, up2 = (np.c_[self.poses[:, :2, j], np.zeros(n)] for j in (0, 1))
        M[:, :3, 0] = up2                       # film x=0 (left) is pixel row 0
        M[:, :3, 1] = np.cross(fwd, up2)        # +z for a proper rotation
        M[:, :3, 2], M[:, :3, 3], M[:, 3, 3] = fwd, np.c_[self.origins, np.zeros(n)], 1
        return M
