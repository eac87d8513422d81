"""Lens distortion: the radial-tangential (Brown-Conrady) model of OpenCV and COLMAP, on normalised image
coordinates (OpenCV axes: ``x`` right, ``y`` down, both divided by the depth).

A point ``(x, y)``, with ``r² = x² + y²`` and ``q = 1 + k1 r² + k2 r⁴ + k3 r⁶``, is seen at::

    x_d = x q + 2 p1 x y + p2 (r² + 2 x²)
    y_d = y q + p1 (r² + 2 y²) + 2 p2 x y

Coefficients are kept in OpenCV's order ``(k1, k2, p1, p2, k3)`` (:data:`COEFFICIENTS`); COLMAP's
``SIMPLE_RADIAL`` (k1), ``RADIAL`` (k1, k2), ``OPENCV`` (k1, k2, p1, p2) and ``FULL_OPENCV`` with
k4 = k5 = k6 = 0 are special cases (:data:`MODELS`). :func:`undistort` inverts the formula by Newton's method.
"""

from __future__ import annotations

import numpy as np

from ..errors import MitnerfError

COEFFICIENTS = ("k1", "k2", "p1", "p2", "k3")
"""The order of a lens's coefficients (OpenCV's ``distCoeffs``)."""
MODELS = {"SIMPLE_PINHOLE": (), "PINHOLE": (), "SIMPLE_RADIAL": ("k1",), "RADIAL": ("k1", "k2"),
          "OPENCV": ("k1", "k2", "p1", "p2")}
"""COLMAP's (and nerfstudio's) pinhole camera models and the coefficients each has."""


def distort(xy: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Where the lens shows undistorted points: ``xy [..., 2]``, ``k [..., 5]`` (broadcast) -> ``[..., 2]``."""
    return _forward(xy, k)[0]


def jacobian(xy: np.ndarray, k: np.ndarray) -> np.ndarray:
    """``[..., 2, 2]``: the derivative of :func:`distort` at ``xy`` (rows: ``x_d``, ``y_d``; columns: ``x``, ``y``)."""
    return _forward(xy, k)[1]


def _forward(xy, k):
    x, y = xy[..., 0], xy[..., 1]
    k1, k2, p1, p2, k3 = (k[..., i] for i in range(5))
    r2 = x * x + y * y
    q = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    dq = k1 + r2 * (2 * k2 + 3 * k3 * r2)                    # dq / d(r²)
    xd = x * q + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * q + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    J = np.empty(np.broadcast_shapes(x.shape, k1.shape) + (2, 2))
    J[..., 0, 0] = q + 2 * x * x * dq + 2 * p1 * y + 6 * p2 * x
    J[..., 0, 1] = J[..., 1, 0] = 2 * x * y * dq + 2 * p1 * x + 2 * p2 * y
    J[..., 1, 1] = q + 2 * y * y * dq + 6 * p1 * y + 2 * p2 * x
    return np.stack([xd, yd], -1), J


def undistort(xy_d: np.ndarray, k: np.ndarray, tol: float = 1e-12, iterations: int = 50) -> np.ndarray:
    """The undistorted points the lens shows at ``xy_d [..., 2]`` (Newton's method from ``xy_d``, until every
    point's residual is below ``tol`` in normalised units, or within rounding of float64); raises when some point
    does not converge."""
    xy_d = np.asarray(xy_d, np.float64)
    xy = xy_d.copy()
    tol = max(tol, 8 * np.finfo(np.float64).eps * max(1.0, float(np.abs(xy_d).max(initial=0.0))))
    for _ in range(iterations):
        f, J = _forward(xy, k)
        res = f - xy_d
        if np.all(np.abs(res) <= tol):
            return xy
        det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.stack([J[..., 1, 1] * res[..., 0] - J[..., 0, 1] * res[..., 1],
                             J[..., 0, 0] * res[..., 1] - J[..., 1, 0] * res[..., 0]], -1) / det[..., None]
        xy = xy - step
    res = np.abs(_forward(xy, k)[0] - xy_d).max(-1)
    if not np.all(res <= tol):
        worst = np.unravel_index(np.nanargmax(np.where(np.isfinite(res), res, np.inf)), res.shape)
        raise MitnerfError(f"lens distortion {np.broadcast_to(k, res.shape + (5,))[worst].tolist()} (k1, k2, p1, p2, "
                           f"k3) cannot be inverted at normalised point {xy_d[worst].tolist()}; check the coefficients")
    return xy


def fold_radius(k) -> float:
    """The undistorted radius at which the radial map ``r -> r q(r)`` stops increasing (``inf``: never): beyond
    it two points share one pixel, so a lens is usable only for images inside ``fold_radius * q``."""
    k1, k2, _, _, k3 = (float(v) for v in k)
    poly = np.trim_zeros([7 * k3, 5 * k2, 3 * k1, 1.0], "f")          # d(r q)/dr as a polynomial in r²
    roots = np.roots(poly) if len(poly) > 1 else []
    s = [r.real for r in roots if abs(r.imag) <= 1e-12 * max(1.0, abs(r)) and r.real > 0]
    return float(np.sqrt(min(s))) if s else float("inf")
