"""Pictures of views a person opens: a few views of a split (or every view of a 2D strip) in labelled rows, the
data's name in the title, at most :data:`MAX_PIXELS` on the longer side; and of a trained model: its curves, its
renders beside the ground truth, its density field."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .panels import colorize_depth, density_image, density_panel, pyplot, save, views_strip

MAX_VIEWS = 6
"""Views a figure shows at most (3D: evenly spread over the split; 2D views are narrow: every view of a strip)."""
MAX_PIXELS = 4096
"""The longest side of any picture mitnerf writes."""


def pick_views(n: int, most: int = MAX_VIEWS) -> np.ndarray:
    """Indices of at most ``most`` views evenly spread over ``n``."""
    return np.unique(np.linspace(0, n - 1, min(n, most)).round().astype(int))


def compare_figure(path: str | Path, rows: list[tuple[str, np.ndarray]], title: str, names=None) -> Path:
    """A labelled grid: one row per ``(label, images [n, H, W, 3])`` (3D: at most :data:`MAX_VIEWS` views a row,
    each a column named by ``names``; 2D: each row one strip of every view), the figure's ``title`` above; at
    most :data:`MAX_PIXELS` on its longer side."""
    n, H, W = rows[0][1].shape[:3]
    strips = W == 1
    cols = 1 if strips else len(pick_views(n))
    keep = np.arange(n) if strips else pick_views(n)
    aspect = (n * 4 / H) if strips else W / H
    cell_w = min(3.2, 14.0 / cols) if not strips else min(12.0, max(4.0, 0.02 * n * 4))
    cell_h = min(3.2, cell_w / aspect) if not strips else 1.6
    dpi = min(110, MAX_PIXELS / max(cell_w * cols + 1.2, cell_h * len(rows) + 0.6))
    fig, axes = pyplot().subplots(len(rows), cols, figsize=(cell_w * cols + 1.2, cell_h * len(rows) + 0.6),
                                  squeeze=False)
    for (label, images), axs in zip(rows, axes):
        tiles = [views_strip(images, 1)] if strips else [images[k] for k in keep]
        for j, (ax, tile) in enumerate(zip(axs, tiles)):
            ax.imshow(np.clip(tile, 0, 1), aspect="auto" if strips else "equal", interpolation="nearest")
            ax.set_xticks([]), ax.set_yticks([])
            if j == 0:
                ax.set_ylabel(label, fontsize=9)
            if label == rows[0][0]:
                ax.set_title(f"{len(images)} views" if strips else (names[keep[j]] if names else f"view {keep[j]}"),
                             fontsize=8)
    fig.suptitle(title, fontsize=10)
    return save(fig, path, dpi=dpi, rect=(0, 0, 1, 0.97))


def split_figures(split, name: str, out: Path, background, near=None, far=None, title: str = "") -> list[Path]:
    """The colour and (where known) depth of a split's views, labelled (:func:`compare_figure`)."""
    rows = [(f"{name} views", split.target(background))]
    if split.depth is not None:
        rows.append(("depth", colorize_depth(split.depth, near, far)))
    return [compare_figure(out / f"{name}_views.png", rows, f"{title}: {name} split, {len(split)} views")]


def plot_curves(history: dict, path: str | Path, title: str = "") -> Path:
    """Training loss and validation PSNR against training time."""
    fig, ax = pyplot().subplots(1, 2, figsize=(10, 3.6))
    ax[0].semilogy(history["time"], history["loss"], lw=1)
    if history.get("val_psnr"):
        ax[1].plot(history["val_time"], history["val_psnr"], "o-")
    for a, ylabel in zip(ax, ("loss", "validation PSNR [dB]")):
        a.set(xlabel="training time [s]", ylabel=ylabel)
        a.grid(alpha=0.3)
    fig.suptitle(title)
    return save(fig, path)


def save_density(density, bound: float, dim: int, path: str | Path, outline=None, title="density") -> Path:
    fig, ax = pyplot().subplots(figsize=(4.4, 4.2))
    density_panel(ax, density_image(density, bound, dim), bound, outline, title)
    fig.colorbar(ax.images[0], ax=ax, fraction=0.046, label="log10(0.01 + sigma)")
    return save(fig, path)


def save_renders(renders: dict, split, background, out: Path, near=None, far=None, prefix: str = "test",
                 title: str = "") -> list[Path]:
    """The model's colour and depth beside the ground truth's, and their difference, on a few of the split's views
    (:func:`compare_figure`)."""
    depth = np.where(renders["opacity"] > 0.5, renders["depth"] / np.maximum(renders["opacity"], 1e-6), np.inf)
    truth, model = split.target(background), np.clip(renders["rgb"], 0, 1)
    rows = [("ground truth", truth), ("model", model), ("error x4", np.clip(4 * np.abs(model - truth), 0, 1))]
    if split.depth is not None:
        rows.append(("true depth", colorize_depth(split.depth, near, far)))
    rows.append(("model depth", colorize_depth(depth, near, far)))
    return [compare_figure(out / f"{prefix}_views.png", rows, f"{title}: {prefix} views")]
