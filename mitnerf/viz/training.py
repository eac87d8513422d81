"""Pictures of a trained model: curves, renders beside ground truth, the density field."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .strips import colorize_depth, contact_sheet, save_image, views_strip


def plot_curves(history: dict, path: str | Path, title: str = "") -> Path:
    """Training loss and validation PSNR against training time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    ax[0].semilogy(history["time"], history["loss"], lw=1)
    ax[0].set_xlabel("training time [s]")
    ax[0].set_ylabel("loss")
    ax[0].grid(alpha=0.3)
    if history.get("val_psnr"):
        ax[1].plot(history["val_time"], history["val_psnr"], "o-")
    ax[1].set_xlabel("training time [s]")
    ax[1].set_ylabel("validation PSNR [dB]")
    ax[1].grid(alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def density_image(density, bound: float, dim: int, res: int = 256) -> np.ndarray:
    """``density(points) -> [m]`` on a ``res x res`` grid over ``[-bound, bound]^2`` (3D: the z = 0
    slice), image row 0 at +y: the picture of a field's geometry."""
    u = np.linspace(-bound, bound, res, dtype=np.float32)
    X, Y = np.meshgrid(u, u[::-1])                      # image row 0 is +y
    pts = np.stack([X.ravel(), Y.ravel()] + ([np.zeros(X.size, np.float32)] if dim == 3 else []), 1)
    return np.asarray(density(pts)).reshape(res, res)


def save_density(density, bound: float, dim: int, path: str | Path, outline=None, title="density") -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sigma = density_image(density, bound, dim)
    fig, ax = plt.subplots(figsize=(4.4, 4.2))
    im = ax.imshow(np.log10(1e-2 + np.maximum(sigma, 0)), cmap="magma", extent=(-bound, bound, -bound, bound))
    if outline is not None:
        pts = np.asarray(outline)
        ax.plot(pts[:, 0], pts[:, 1], color="cyan", lw=0.8, alpha=0.8)
    fig.colorbar(im, ax=ax, fraction=0.046, label="log10(0.01 + sigma)")
    ax.set_title(title)
    ax.set_xticks([]), ax.set_yticks([])
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def save_renders(renders: dict, split, background, out: Path, near=None, far=None, prefix: str = "test") -> list[Path]:
    """Prediction beside ground truth (colour and depth). 2D: strips stacked; 3D: sheets."""
    target = split.target(background)
    depth = renders["depth"] / np.maximum(renders["opacity"], 1e-6)
    depth = np.where(renders["opacity"] > 0.5, depth, np.inf)
    gt_depth = split.depth if split.depth is not None else np.full(depth.shape, np.inf)
    if split.cameras.dim == 2:
        gap = np.ones((4,) + views_strip(target).shape[1:], np.float32)
        col = np.concatenate([views_strip(target), gap, views_strip(renders["rgb"])], 0)
        dep = np.concatenate([views_strip(colorize_depth(gt_depth, near, far)), gap,
                              views_strip(colorize_depth(depth, near, far))], 0)
        scale = 2
    else:
        col = np.concatenate([contact_sheet(target), contact_sheet(np.clip(renders["rgb"], 0, 1))], 0)
        dep = np.concatenate([contact_sheet(colorize_depth(gt_depth, near, far)),
                              contact_sheet(colorize_depth(depth, near, far))], 0)
        scale = 1
    return [save_image(out / f"{prefix}_views.png", col, scale), save_image(out / f"{prefix}_depth.png", dep, scale)]
