"""Matplotlib panels shared by the experiments' figure grids (views strips, depth, density)."""

from __future__ import annotations

import numpy as np

from .strips import colorize_depth, views_strip
from .training import density_image


def strip_panel(ax, images: np.ndarray, title: str = "") -> None:
    """2D views ``[n, H, 1, 3]`` as a views strip."""
    ax.imshow(np.clip(views_strip(images, column_width=1), 0, 1), aspect="auto", interpolation="nearest")
    ax.set_title(title, fontsize=8)
    ax.set_xticks([]), ax.set_yticks([])


def depth_panel(ax, depth: np.ndarray, opacity: np.ndarray | None, near: float, far: float, title: str = "") -> None:
    """Termination depth of 2D views as a strip; pixels with opacity < 0.5 are black."""
    d = depth if opacity is None else np.where(opacity > 0.5, depth / np.maximum(opacity, 1e-6), np.inf)
    ax.imshow(views_strip(colorize_depth(d, near, far), column_width=1), aspect="auto", interpolation="nearest")
    ax.set_title(title, fontsize=8)
    ax.set_xticks([]), ax.set_yticks([])


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


def save(fig, path, dpi: int = 110) -> None:
    """Lay out, write and close a figure."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def pyplot():
    """matplotlib's pyplot on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
