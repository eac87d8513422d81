"""Image and geometry metrics on numpy arrays (display-space colours in [0, 1])."""

from __future__ import annotations

import numpy as np


def psnr(pred: np.ndarray, target: np.ndarray) -> float:
    mse = float(np.mean((np.clip(pred, 0, 1) - target) ** 2))
    return float("inf") if mse == 0 else -10.0 * np.log10(mse)


def ssim(pred: np.ndarray, target: np.ndarray) -> float:
    """Mean SSIM over views ``[n, H, W, 3]`` (scikit-image). 1D views (W = 1) use a 1D window."""
    from skimage.metrics import structural_similarity

    vals = []
    for p, t in zip(np.clip(pred, 0, 1), target):
        if p.shape[1] == 1:
            p, t = p[:, 0], t[:, 0]               # [H, 3]: a 1D signal with channels
        win = min(7, *[s if s % 2 else s - 1 for s in p.shape[:-1]])
        vals.append(structural_similarity(p, t, channel_axis=-1, data_range=1.0, win_size=max(win, 3)))
    return float(np.mean(vals))


def depth_error(depth: np.ndarray, opacity: np.ndarray, gt: np.ndarray, mask: np.ndarray) -> float:
    """Mean absolute error of the termination depth (``sum w t / sum w``) on the pixels in ``mask``."""
    if not mask.any():
        return float("nan")
    d = depth[mask] / np.maximum(opacity[mask], 1e-6)
    return float(np.mean(np.abs(d - gt[mask])))
