"""Matplotlib helpers shared by the figures: pyplot, saving, image strips (the NeRF2D "views strip": every 1D view a
column) and depth colours, the density image, the experiments' panels, and charts of result tables (rows as dicts:
series against a setting, side by side)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np


def pyplot():
    """matplotlib's pyplot on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save(fig, path, dpi: int = 110, rect=None) -> Path:
    """Lay out (within ``rect`` of the figure), write and close a figure; returns the path."""
    import matplotlib.pyplot as plt

    fig.tight_layout(rect=rect)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return Path(path)


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


def density_image(density, bound: float, dim: int, res: int = 256) -> np.ndarray:
    """``density(points) -> [m]`` on a ``res x res`` grid over ``[-bound, bound]^2`` (3D: the z = 0
    slice), image row 0 at +y: the picture of a field's geometry."""
    u = np.linspace(-bound, bound, res, dtype=np.float32)
    X, Y = np.meshgrid(u, u[::-1])                      # image row 0 is +y
    pts = np.stack([X.ravel(), Y.ravel()] + ([np.zeros(X.size, np.float32)] if dim == 3 else []), 1)
    return np.asarray(density(pts)).reshape(res, res)


def strip_panel(ax, images: np.ndarray, title: str = "") -> None:
    """2D views ``[n, H, 1, 3]`` as a views strip."""
    ax.imshow(np.clip(views_strip(images, column_width=1), 0, 1), aspect="auto", interpolation="nearest")
    ax.set_title(title, fontsize=8)
    ax.set_xticks([]), ax.set_yticks([])


def depth_panel(ax, depth: np.ndarray, opacity: np.ndarray | None, near: float, far: float, title: str = "") -> None:
    """Termination depth of 2D views as a strip; pixels with opacity < 0.5 are black."""
    d = depth if opacity is None else np.where(opacity > 0.5, depth / np.maximum(opacity, 1e-6), np.inf)
    strip_panel(ax, colorize_depth(d, near, far), title)


def density_panel(ax, source, bound: float, outline=None, title: str = "", res: int = 160) -> None:
    """Density over ``[-bound, bound]^2`` (log scale), the true outline on top. ``source`` is
    a density function (sampled on a ``res x res`` grid) or that grid already."""
    sigma = source if isinstance(source, np.ndarray) else density_image(source, bound, 2, res)
    ax.imshow(np.log10(1e-2 + np.maximum(sigma, 0)), cmap="magma", extent=(-bound, bound, -bound, bound),
              vmin=-2, vmax=2.5)
    if outline is not None:
        pts = np.asarray(outline)
        ax.plot(pts[:, 0], pts[:, 1], color="cyan", lw=0.6, alpha=0.8)
    ax.set_title(title, fontsize=8)
    ax.set_xticks([]), ax.set_yticks([])


def image_panel(ax, image: np.ndarray, title: str = "") -> None:
    """One image ``[H, W, 3]`` (clipped to [0, 1]), no axes."""
    ax.imshow(np.clip(image, 0, 1))
    ax.set_title(title, fontsize=7)
    ax.axis("off")


def image_grid(path, rows: list[list], cell=(3.0, 1.2), dpi: int = 110) -> Path:
    """A figure of panels row by row, each ``cell`` inches: every panel is ``(draw, *args)``, ``draw(ax, *args)``
    one of this module's panels; ``None`` (or a short row) leaves a cell empty."""
    m = max(1, *(len(r) for r in rows))
    fig, axes = pyplot().subplots(len(rows), m, figsize=(cell[0] * m, cell[1] * len(rows)), squeeze=False)
    for row, axs in zip(rows, axes):
        for panel, ax in zip(list(row) + [None] * m, axs):
            if panel is None:
                ax.axis("off")
            else:
                panel[0](ax, *panel[1:])
    return save(fig, path, dpi=dpi)


def num(v) -> float:
    """``v`` as a float; NaN where it is none (an empty CSV cell, text)."""
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def series(ax, rows: list[dict], x: str, y: str = "psnr", by: tuple = (), styles: dict | None = None,
           err: bool = True) -> None:
    """One line per value of the ``by`` columns: ``y`` against ``x`` (error bars: the ``<y>_std`` column of a
    summary), a row's ``label`` written beside its point; ``styles`` maps the last ``by`` value to a format."""
    groups: dict = {}
    for r in rows:
        groups.setdefault(tuple(r[k] for k in by), []).append(r)
    for key, rs in groups.items():
        rs = sorted(rs, key=lambda r: num(r[x]))
        xs, ys = [num(r[x]) for r in rs], [num(r[y]) for r in rs]
        ax.errorbar(xs, ys, yerr=[num(r.get(f"{y}_std")) for r in rs] if err else None, capsize=2,
                    fmt=(styles or {}).get(key[-1] if key else None, "o-"), label=", ".join(map(str, key)) or None)
        for r, xy in zip(rs, zip(xs, ys)):
            if "label" in r:
                ax.annotate(r["label"], xy, fontsize=7, xytext=(3, 2), textcoords="offset points")


def series_figure(path: Path, panels: list[dict], title: str = "", cell=(4.5, 3.4), columns: int = 0) -> Path:
    """Charts side by side (``columns`` to a row; 0: all), each ``dict(title=, xlabel=, ylabel= (test PSNR), xscale=,
    yscale=, xticks=, xticklabels=, **`` :func:`series` ``arguments)``."""
    m = columns or len(panels)
    n = math.ceil(len(panels) / m)
    fig, axes = pyplot().subplots(n, m, figsize=(cell[0] * m, cell[1] * n), squeeze=False)
    for ax in axes.flat[len(panels):]:
        ax.axis("off")
    for ax, p in zip(axes.flat, panels):
        p = {"ylabel": "test PSNR [dB]", **p}
        ax.set(**{k: p.pop(k) for k in ("title", "xlabel", "ylabel", "xscale", "yscale", "xticks", "xticklabels")
                  if k in p})
        series(ax, **p)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[1]:
            ax.legend(fontsize=7)
    fig.suptitle(title)
    return save(fig, path)
