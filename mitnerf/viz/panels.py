"""Matplotlib helpers shared by the figures: pyplot, saving, the density image, the experiments' panels."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .strips import colorize_depth, views_strip


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
