"""Camera rigs, the NeRF2D protocol: train and val cameras are placed at random (or evenly, for
sparse-view studies) and perturbed by Gaussian noise; test cameras are evenly spaced and noise-free.
2D rigs use a circle in the z = 0 plane; 3D rigs a sphere or the upper hemisphere (test views: an orbit).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ..settings import check, setting
from .cameras import Cameras


@dataclass
class RigConfig:
    """Camera placement. Every random draw comes from ``numpy.random.default_rng(seed)``."""

    dim: Literal[2, 3] = setting(2, choices=(2, 3))
    """2: a circle in the z = 0 plane (1D views). 3: a (hemi)sphere (2D images)."""
    n_train: int = setting(50, lo=1, hi=100_000, flag="--views")
    """Training views (random and noisy)."""
    n_val: int = setting(10, lo=0, hi=100_000, flag="--val")
    """Validation views (random and noisy)."""
    n_test: int = setting(20, lo=0, hi=100_000, flag="--test")
    """Test views: evenly spaced, noise-free (in 3D: an orbit at ``test_elevation``)."""
    radius: float | None = setting(None, lo=0, above=True, hi=1e4, flag="--radius", unit="world units")
    """Distance of the cameras from the origin (world units). Default: 4 in 2D (NeRF2D), 3.5 in 3D."""
    resolution: int = setting(100, lo=1, hi=16384, flag="--image-size", unit="pixels")
    """Pixels along the 1D image (2D) or along each side of the image (3D)."""
    fov: float | None = setting(None, lo=0, above=True, hi=179, flag="--fov", unit="degrees")
    """Field of view in degrees (2D: along the image; 3D: horizontal). Default: 53.13 in 2D (NeRF2D), 40 in 3D."""
    layout: Literal["random", "even"] = setting("random", flag="--layout")
    """Train/val placement: uniform at random, or evenly spaced (sparse-view studies)."""
    surface: Literal["hemisphere", "sphere"] = setting("hemisphere")
    """3D only: where train/val cameras may stand."""
    test_elevation: float = setting(25.0, lo=-89.9, hi=89.9, unit="degrees")
    """3D only: elevation of the test orbit in degrees."""
    radius_std: float = setting(0.0, lo=0, hi=1e4, flag="--radius-std", unit="world units")
    """Gaussian noise on the camera distance (world units)."""
    angle_std: float = setting(0.0, lo=0, hi=1e4, flag="--angle-std", unit="degrees")
    """Gaussian noise on the placement angle(s) in degrees (2D: around the circle; 3D: azimuth and elevation)."""
    position_std: float = setting(0.0, lo=0, hi=1e4, flag="--position-std", unit="world units")
    """Isotropic Gaussian jitter of the camera position (world units), after placement."""
    look_std: float = setting(0.0, lo=0, hi=1e4, flag="--look-std", unit="degrees")
    """Gaussian noise on the viewing direction in degrees (2D: one angle; 3D: yaw and pitch)."""
    seed: int = setting(0, lo=0, hi=2 ** 32 - 1, flag="--seed")
    """Seed of the placement noise."""

    def __post_init__(self):
        if self.radius is None:
            self.radius = 4.0 if self.dim == 2 else 3.5

    @property
    def focal(self) -> float:
        fov = self.fov if self.fov is not None else (53.13010235415598 if self.dim == 2 else 40.0)
        return self.resolution / 2 / np.tan(np.radians(fov) / 2)

    def validate(self) -> None:
        check(self)


def noise_preset(level: float) -> dict[str, float]:
    """Noise parameters scaled by one knob (``--noise``): 1 is radius 0.1, angles 2 deg, position 0.05, look 1 deg."""
    return dict(radius_std=0.1 * level, angle_std=2.0 * level, position_std=0.05 * level, look_std=1.0 * level)


def look_at_2d(position: np.ndarray, view_angle: np.ndarray) -> np.ndarray:
    """3x3 poses of cameras at ``position [n, 2]`` looking along ``view_angle [n]``."""
    c, s = np.cos(view_angle), np.sin(view_angle)
    P = np.zeros((len(c), 3, 3))
    P[:, 0, 0], P[:, 1, 0] = c, s          # forward
    P[:, 0, 1], P[:, 1, 1] = -s, c         # up: forward turned by +90 degrees
    P[:, :2, 2], P[:, 2, 2] = position, 1
    return P


def look_at_3d(position: np.ndarray, forward: np.ndarray, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """4x4 OpenGL-style poses (looking down -z) at ``position [n, 3]`` along ``forward``."""
    f = forward / np.linalg.norm(forward, axis=1, keepdims=True)
    right = np.cross(f, np.asarray(up, float))
    right /= np.linalg.norm(right, axis=1, keepdims=True)
    cam_up = np.cross(right, f)
    P = np.zeros((len(f), 4, 4))
    P[:, :3, 0], P[:, :3, 1], P[:, :3, 2], P[:, :3, 3] = right, cam_up, -f, position
    P[:, 3, 3] = 1
    return P


def _place(cfg: RigConfig, n: int, rng, test: bool, offset: float = 0.0) -> np.ndarray:
    """Poses of ``n`` cameras: evenly spaced and noise-free (``test``), or placed by ``cfg.layout`` and
    perturbed (train/val; a 2D even layout starts at the angle ``offset``)."""
    ring, max_el = 2 * np.pi * np.arange(n) / max(n, 1), np.radians(80.0)
    lo = 0.0 if cfg.surface == "hemisphere" else -np.sin(max_el)
    if cfg.dim == 2:             # angles: [around the circle]; 3D: [azimuth, elevation]
        angles = [offset + ring if test or cfg.layout == "even" else rng.uniform(0, 2 * np.pi, n)]
    elif test:
        angles = [ring, np.full(n, np.radians(cfg.test_elevation))]
    elif cfg.layout == "even":   # a Fibonacci lattice on the allowed band, randomly turned
        k = np.arange(n) + 0.5
        el = np.arcsin(lo + (np.sin(max_el) - lo) * k / max(n, 1))
        angles = [np.pi * (1 + 5 ** 0.5) * k + rng.uniform(0, 2 * np.pi), el]
    else:                        # uniform on the sphere band (area-preserving)
        el = np.arcsin(rng.uniform(lo, np.sin(max_el), n))
        angles = [rng.uniform(0, 2 * np.pi, n), el]
    # look-at noise: 2D [one angle]; 3D [yaw, pitch]
    radius, jitter, look = np.full(n, cfg.radius), np.zeros((n, cfg.dim)), [np.zeros(n)] * (cfg.dim - 1)
    if not test:
        angles = [a + np.radians(cfg.angle_std) * rng.standard_normal(n) for a in angles]
        radius = radius + cfg.radius_std * rng.standard_normal(n)
        jitter = cfg.position_std * rng.standard_normal((n, cfg.dim))
        look = [np.radians(cfg.look_std) * rng.standard_normal(n) for _ in range(cfg.dim - 1)]
    if cfg.dim == 2:
        pos = radius[:, None] * np.stack([np.cos(angles[0]), np.sin(angles[0])], 1) + jitter
        return look_at_2d(pos, np.arctan2(-pos[:, 1], -pos[:, 0]) + look[0])    # the origin, up to the noise
    az, el = angles[0], angles[1] if test else np.clip(angles[1], -max_el, max_el)
    pos = radius[:, None] * np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], 1) + jitter
    P = look_at_3d(pos, -pos)
    # look-at noise: turn the forward axis by (yaw, pitch) about the camera's up and right axes
    (yaw, pitch), f, r, u = look, -P[:, :3, 2], P[:, :3, 0], P[:, :3, 1]
    f2 = ((np.cos(yaw) * np.cos(pitch))[:, None] * f + np.sin(yaw)[:, None] * r
          + (np.cos(yaw) * np.sin(pitch))[:, None] * u)
    return look_at_3d(pos, f2)


@dataclass
class Rig:
    """Cameras of every split."""

    train: Cameras
    val: Cameras
    test: Cameras
    config: RigConfig = field(repr=False)

    def splits(self) -> dict[str, Cameras]:
        return {"train": self.train, "val": self.val, "test": self.test}


def make_rig(cfg: RigConfig) -> Rig:
    """Place the cameras of every split (deterministic for ``cfg.seed``)."""
    cfg.validate()
    rng = np.random.default_rng(cfg.seed)
    offset = rng.uniform(0, 2 * np.pi) if cfg.dim == 2 else 0.0     # turns 2D even layouts off the test views
    poses = [_place(cfg, cfg.n_train, rng, False, offset),
             _place(cfg, cfg.n_val, rng, False, offset + np.pi / max(cfg.n_val, 1)), _place(cfg, cfg.n_test, rng, True)]
    W = 1 if cfg.dim == 2 else cfg.resolution
    return Rig(*(Cameras(p, cfg.focal, cfg.resolution, W) for p in poses), cfg)
