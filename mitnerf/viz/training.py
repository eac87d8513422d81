"""Pictures of a trained model: curves, renders beside ground truth, the density field."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .panels import density_image, density_panel, pyplot, save
from .strips import colorize_depth
from .views import compare_figure


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
    (:func:`~.strips.compare_figure`)."""
    depth = np.where(renders["opacity"] > 0.5, renders["depth"] / np.maximum(renders["opacity"], 1e-6), np.inf)
    truth, model = split.target(background), np.clip(renders["rgb"], 0, 1)
    rows = [("ground truth", truth), ("model", model), ("error x4", np.clip(4 * np.abs(model - truth), 0, 1))]
    if split.depth is not None:
        rows.append(("true depth", colorize_depth(split.depth, near, far)))
    rows.append(("model depth", colorize_depth(depth, near, far)))
    return [compare_figure(out / f"{prefix}_views.png", rows, f"{title}: {prefix} views")]
