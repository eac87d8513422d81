"""Pinhole cameras and their pixel-centre rays, in numpy.

Conventions (the same as the file formats, so rays never need converting):

* **2D (NeRF2D)**: a pose is a 3x3 camera-to-world matrix in homogeneous 2D coordinates: column 0 is the
  viewing direction, column 1 the camera's "up" (towards pixel row 0), column 2 the position. Pixel row ``i``
  of an ``H``-pixel view looks along ``normalize([f, H/2 - (i + 0.5)])`` in camera space.
* **3D (Blender / nerfstudio / OpenGL)**: a pose is a 4x4 camera-to-world matrix;
  the camera looks down -z with +y up and +x right. Pixel ``(row v, column u)`` looks
  along ``normalize([(u + 0.5 - W/2) / f, -(v + 0.5 - H/2) / f, -1])``.

Directions are unit length, so a depth is the distance along the pixel-centre ray.
Images are ``[n, H, W, ...]``; a 2D view is ``H`` pixels tall and one pixel wide.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._io import available_memory
from ..errors import ConfigError, MitnerfError

PIXEL_BYTES = 32
"""The least memory a pixel of a set of views costs once rendered (colour, alpha, depth, mask)."""


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
    """A set of pinhole cameras sharing one focal length and resolution."""

    poses: np.ndarray
    """``[n, 3, 3]`` (2D) or ``[n, 4, 4]`` (3D) camera-to-world matrices."""
    focal: float
    """Focal length in pixels."""
    height: int
    """Pixel rows (in 2D the length of the 1D image)."""
    width: int = 1
    """Pixel columns (1 in 2D)."""

    def __post_init__(self):
        self.poses = np.asarray(self.poses, dtype=np.float64)
        if self.poses.ndim != 3 or self.poses.shape[1:] not in ((3, 3), (4, 4)):
            raise MitnerfError(f"poses must be [n, 3, 3] (2D) or [n, 4, 4] (3D), got {self.poses.shape}")
        bad = np.flatnonzero(~np.isfinite(self.poses).all(axis=(1, 2)))
        if len(bad):
            raise MitnerfError(f"pose {bad[0]} contains NaN or infinity; fix or drop that frame")
        if not (np.isfinite(self.focal) and self.focal > 0):
            raise MitnerfError(f"focal length must be a positive number of pixels, got {self.focal}")
        if self.height < 1 or self.width < 1:
            raise MitnerfError(f"resolution must be at least 1 pixel, got {self.height}x{self.width}")
        if self.dim == 2 and self.width != 1:
            raise MitnerfError("2D cameras see 1D images: width must be 1")
        check_pixel_memory(len(self.poses), self.height, self.width)

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
    def fov(self) -> float:
        """Field of view in degrees along the image length (2D) or width (3D)."""
        n = self.height if self.dim == 2 else self.width
        return float(np.degrees(2 * np.arctan(n / (2 * self.focal))))

    def subset(self, index) -> "Cameras":
        return Cameras(self.poses[index], self.focal, self.height, self.width)

    def _raw_directions(self) -> np.ndarray:
        """Pixel-centre directions in camera space, not normalised, ``[H, W, dim]``."""
        f, H, W = self.focal, self.height, self.width
        if self.dim == 2:
            return np.stack([np.full(H, f), H / 2 - (np.arange(H) + 0.5)], -1)[:, None, :]
        U, V = np.meshgrid((np.arange(W) + 0.5 - W / 2) / f, -(np.arange(H) + 0.5 - H / 2) / f)
        return np.stack([U, V, -np.ones_like(U)], -1)

    def camera_directions(self) -> np.ndarray:
        """Unit pixel-centre directions in camera space, ``[H, W, dim]``."""
        d = self._raw_directions()
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def footprint(self) -> np.ndarray:
        """Each pixel's extent as steps of its unit direction, ``[n, H, W, 2, dim]``: the ray
        through the point ``(a, b)`` of pixel ``(v, u)`` (``a, b`` in [-1/2, 1/2], 0 at the
        centre) has the direction ``normalize(d + a s_0 + b s_1)``. In 2D ``s_0`` steps one row
        and ``s_1`` is zero (1D views)."""
        raw, f, k = self._raw_directions(), self.focal, self.dim
        s = [[0.0, -1.0], [0.0, 0.0]] if k == 2 else [[1 / f, 0, 0], [0, -1 / f, 0]]
        steps = np.broadcast_to(s, raw.shape[:2] + (2, k)) / np.linalg.norm(raw, axis=-1)[..., None, None]
        return np.einsum("nij,hwsj->nhwsi", self.poses[:, :k, :k], steps)        # steps: [H, W, 2, dim]

    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        """Origins and unit directions of every pixel-centre ray, each ``[n, H, W, dim]``."""
        k = self.dim
        d = np.einsum("nij,hwj->nhwi", self.poses[:, :k, :k], self.camera_directions())
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        o = np.broadcast_to(self.origins[:, None, None, :], d.shape)
        return np.ascontiguousarray(o), d

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """World points ``[m, dim]`` in every camera's axes, ``[n, m, dim]`` (the poses' rotations are orthonormal)."""
        k = self.dim
        return np.einsum("nji,nmj->nmi", self.poses[:, :k, :k], points[None] - self.origins[:, None])

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Continuous pixel coordinates of world points in every camera (2D only): ``points [m, 2]`` ->
        ``(row [n, m], forward [n, m])``. Pixel ``floor(row)`` sees the point (the centre ray of pixel ``i``
        has ``row == i + 0.5``); ``forward`` is the camera-space distance along the view axis (> 0 in front)."""
        if self.dim != 2:
            raise NotImplementedError("project() is defined for 2D cameras")
        cam = self.to_camera(points)                          # [n, m, 2]
        fwd, up = cam[..., 0], cam[..., 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            row = self.height / 2 - self.focal * up / fwd
        return row, fwd

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
