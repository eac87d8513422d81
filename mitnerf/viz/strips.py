"""Image strips (the NeRF2D "views strip": every 1D view a column), depth colours, 3D contact sheets, PNG files."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..data.color import to_uint8


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


def save_image(path: str | Path, image: np.ndarray, scale: int = 1) -> Path:
    """Save a float [0, 1] (or uint8) image, optionally scaled up by pixel repetition."""
    import imageio.v3 as iio

    img = image if image.dtype == np.uint8 else to_uint8(image)
    if scale > 1:
        img = np.repeat(np.repeat(img, scale, 0), scale, 1)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, img)
    return path
