"""Image strips (the NeRF2D "views strip": every 1D view a column) and depth colours."""

from __future__ import annotations

import numpy as np


def views_strip(images: np.ndarray, column_width: int = 4) -> np.ndarray:
    """``[n, H, 1, 3]`` display-space views -> ``[H, n * column_width, 3]`` (one column each)."""
    strip = np.asarray(images)[:, :, 0, :].transpose(1, 0, 2)    # [H, n, 3]
    return np.repeat(strip, column_width, axis=1)


def colorize_depth(depth: np.ndarray, near: float | None = None, far: float | None = None,
                   cmap: str = "viridis") -> np.ndarray:
    """Depth ``[...]`` (``inf`` = miss) -> RGB in [0, 1] ``[..., 3]``; misses are black."""
    from matplotlib import colormaps

    hit = np.isfinite(depth)
    if not hit.any():
        return np.zeros(depth.shape + (3,), np.float32)
    lo = depth[hit].min() if near is None else near
    hi = depth[hit].max() if far is None else far
    t = np.clip((np.where(hit, depth, lo) - lo) / max(hi - lo, 1e-9), 0, 1)
    rgb = colormaps[cmap](1.0 - t)[..., :3]                      # near = bright
    return np.where(hit[..., None], rgb, 0.0).astype(np.float32)

