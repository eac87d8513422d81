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


def contact_sheet(images: np.ndarray, columns: int = 8, pad: int = 2) -> np.ndarray:
    """``[n, H, W, 3]`` -> one grid image with ``columns`` images per row."""
    n, H, W = images.shape[:3]
    rows = int(np.ceil(n / columns))
    sheet = np.ones((rows * (H + pad) + pad, columns * (W + pad) + pad, 3), np.float32)
    for k in range(n):
        r, c = divmod(k, columns)
        y, x = pad + r * (H + pad), pad + c * (W + pad)
        sheet[y:y + H, x:x + W] = images[k]
    return sheet


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


def split_figures(split, name: str, out: Path, background, near=None, far=None) -> list[Path]:
    """Colour and depth strips (2D) or sheets (3D) of one split."""
    tile, scale = (views_strip, 2) if split.cameras.dim == 2 else (contact_sheet, 1)
    paths = [save_image(out / f"{name}_views.png", tile(split.target(background)), scale)]
    if split.depth is not None:
        paths.append(save_image(out / f"{name}_depth.png", tile(colorize_depth(split.depth, near, far)), scale))
    return paths
