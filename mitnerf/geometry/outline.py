"""Geometry of a 2D field: the solid its density encloses, and its IoU with the true outline.

The *solid* is the cells whose density reaches ``level`` (:data:`mitnerf.geometry.mesh.LEVEL`) with every hole
they enclose filled (``scipy.ndimage.binary_fill_holes``): a field never learns what lies behind an opaque wall,
so a concavity that its density fills in counts as solid and lowers the IoU.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .mesh import LEVEL


def grid_points(bound: float, res: int) -> np.ndarray:
    """Cell centres of a ``res x res`` grid over ``[-bound, bound]^2``, row 0 at +y, ``[res * res, 2]``."""
    u = (np.arange(res) + 0.5) / res * 2 * bound - bound
    X, Y = np.meshgrid(u, u[::-1])
    return np.stack([X.ravel(), Y.ravel()], 1).astype(np.float32)


def solid(density: Callable[[np.ndarray], np.ndarray], bound: float, res: int = 256,
          level: float = LEVEL) -> np.ndarray:
    """``[res, res]`` bool: where the field is solid (see the module docstring)."""
    from scipy.ndimage import binary_fill_holes

    sigma = np.asarray(density(grid_points(bound, res))).reshape(res, res)
    return binary_fill_holes(np.nan_to_num(sigma, nan=0.0) >= level)


def outline_iou(density: Callable[[np.ndarray], np.ndarray], polygon: np.ndarray, bound: float, res: int = 256,
                level: float = LEVEL) -> float:
    """Intersection over union of the field's solid and the polygon ``[k, 2]`` (closed or not)."""
    from matplotlib.path import Path

    inside = Path(np.asarray(polygon, np.float64)).contains_points(grid_points(bound, res)).reshape(res, res)
    mine = solid(density, bound, res, level)
    union = np.logical_or(inside, mine).sum()
    return float(np.logical_and(inside, mine).sum() / union) if union else float("nan")
