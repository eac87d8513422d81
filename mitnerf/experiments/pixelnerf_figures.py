"""Figures of the pixelNeRF experiment (matplotlib, Agg): PSNR against views, test-view
strips per method, density fields, training loss."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..viz.strips import views_strip
from .figures import density_panel, save


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_psnr(rows: list[dict], methods: list[str], ks, path: Path) -> Path:
    """One panel per evaluation scene plus the outline groups: PSNR against k per method."""
    plt = _plt()
    panels = list(dict.fromkeys(r["scene"] for r in rows if r["group"] == "eval"))
    panels += [g for g in ("seen outline", "unseen outline") if any(r["group"] == g for r in rows)]
    fig, axes = plt.subplots(1, len(panels), figsize=(3.6 * len(panels), 3.4), squeeze=False)
    for ax, panel in zip(axes[0], panels):
        for m in methods:
            pick = [r for r in rows if r["method"] == m and (r["scene"] == panel or r["group"] == panel)]
            xs = [k for k in ks if any(r["k"] == k for r in pick)]
            if not xs:
                continue
            ys = [np.nanmean([float(r["psnr"]) for r in pick if r["k"] == k]) for k in xs]
            ax.plot(xs, ys, "o-", label=m)
        ax.set_title(panel)
        ax.set_xlabel("input views k")
        ax.set_xticks(list(ks))
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("test PSNR [dB]")
    axes[0][0].legend(fontsize=8)
    save(fig, path, dpi=110)
    return path


def save_strips(target: np.ndarray, renders: dict, scene: str, ks, methods: list[str], path: Path) -> Path:
    """Rows per k: ground truth, then each method's test views (one column per view)."""
    plt = _plt()
    labels = ["ground truth"] + methods
    fig, axes = plt.subplots(len(ks), 1, figsize=(1.0 + 0.28 * target.shape[0] * 1.0, 1.9 * len(ks)), squeeze=False)
    gap = np.ones((6, target.shape[0] * 4, 3), np.float32)
    for ax, k in zip(axes[:, 0], ks):
        parts, ticks = [], []
        for lab in labels:
            img = target if lab == "ground truth" else renders.get((scene, k, lab))
            if img is None:
                img = np.full_like(target, 0.5)
            ticks.append(sum(p.shape[0] for p in parts) + target.shape[1] / 2)
            parts += [views_strip(np.clip(img, 0, 1)), gap]
        ax.imshow(np.concatenate(parts[:-1], 0), aspect="auto", interpolation="nearest")
        ax.set_yticks(ticks)
        ax.set_yticklabels(labels, fontsize=7)
        ax.set_xticks([])
        ax.set_title(f"{scene}, k = {k} input views", fontsize=9)
    save(fig, path, dpi=100)
    return path


def save_densities(densities: dict, scene: str, ks, methods: list[str], outline, bound: float, path: Path) -> Path:
    """Grid: rows k, columns methods; log10(0.01 + sigma) with the true outline."""
    plt = _plt()
    fig, axes = plt.subplots(len(ks), len(methods), figsize=(2.6 * len(methods), 2.5 * len(ks)), squeeze=False)
    for i, k in enumerate(ks):
        for j, m in enumerate(methods):
            ax = axes[i, j]
            sigma = densities.get((scene, k, m))
            density_panel(ax, sigma if sigma is not None else np.zeros((2, 2)), bound, outline,
                          m if i == 0 else "")
            if j == 0:
                ax.set_ylabel(f"k = {k}")
    fig.suptitle(f"{scene}: density", fontsize=9)
    save(fig, path, dpi=90)
    return path


def plot_training(hist_rows: list[dict], path: Path) -> Path:
    """pixelNeRF training loss (running mean over 100 steps) against training time."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5.5, 3.4))
    for enc in dict.fromkeys(r["encoder"] for r in hist_rows):
        t = np.array([r["time"] for r in hist_rows if r["encoder"] == enc], float)
        loss = np.array([r["loss"] for r in hist_rows if r["encoder"] == enc], float)
        w = min(100, len(loss))
        if w:
            smooth = np.convolve(loss, np.ones(w) / w, mode="valid")
            ax.semilogy(t[w - 1:], smooth, label=f"{enc} encoder")
    ax.set_xlabel("training time [s]")
    ax.set_ylabel("MSE (100-step mean)")
    ax.grid(alpha=0.3)
    ax.legend()
    save(fig, path, dpi=110)
    return path
