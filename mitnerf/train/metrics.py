"""Image and geometry metrics on numpy arrays (display-space colours in [0, 1])."""

from __future__ import annotations

import numpy as np

from ..errors import MitnerfError


def psnr(pred: np.ndarray, target: np.ndarray) -> float:
    mse = float(np.mean((np.clip(pred, 0, 1) - target) ** 2))
    return float("inf") if mse == 0 else -10.0 * np.log10(mse)


SSIM_K = (0.01, 0.03)
"""SSIM's constants ``K1, K2`` (``C = (K data_range)^2``), as scikit-image and Wang et al. (2004) set them."""


def ssim(pred: np.ndarray, target: np.ndarray) -> float:
    """Mean SSIM over views ``[n, H, W, 3]``: scikit-image's ``structural_similarity`` with its defaults (a 7 x 7
    uniform window, sample covariances, :data:`SSIM_K`, data range 1, the window's half-width cropped at the border,
    the channels averaged), computed for the three channels at once; ``tests/test_metrics.py`` holds it to
    scikit-image's figure. 1D views (W = 1) use a 1D window; views smaller than 7 pixels a smaller odd one, and
    views need at least 3 pixels along each axis (as scikit-image's smallest window)."""
    from scipy.ndimage import uniform_filter1d

    c1, c2 = (k * k for k in SSIM_K)
    vals = []
    for p, t in zip(np.clip(pred, 0, 1), target):
        if p.shape[1] == 1:
            p, t = p[:, 0], t[:, 0]               # [H, 3]: a 1D signal with channels
        if min(p.shape[:-1]) < 3:
            raise MitnerfError(f"SSIM needs views of at least 3 pixels along each axis, not {p.shape[:-1]}; "
                               "score larger views")
        win = min(7, *[s if s % 2 else s - 1 for s in p.shape[:-1]])
        p, t = (np.ascontiguousarray(np.moveaxis(a, -1, 0), np.float32) for a in (p, t))     # [3, H(, W)]

        def mean(x: np.ndarray) -> np.ndarray:             # the window's mean, axis by axis
            for axis in range(1, x.ndim):
                x = uniform_filter1d(x, win, axis=axis)
            return x

        ux, uy, uxx, uyy, uxy = (mean(x) for x in (p, t, p * p, t * t, p * t))
        cov = win ** (p.ndim - 1) / (win ** (p.ndim - 1) - 1.0)                 # sample covariances
        vx, vy, vxy = cov * (uxx - ux * ux), cov * (uyy - uy * uy), cov * (uxy - ux * uy)
        s = (2 * ux * uy + c1) * (2 * vxy + c2) / ((ux * ux + uy * uy + c1) * (vx + vy + c2))
        r = (win - 1) // 2
        inner = s[(slice(None),) + (slice(r, -r),) * (p.ndim - 1)]
        vals.append(inner.reshape(len(inner), -1).mean(1, dtype=np.float64).mean())
    return float(np.mean(vals))


def depth_error(depth: np.ndarray, opacity: np.ndarray, gt: np.ndarray, mask: np.ndarray) -> float:
    """Mean absolute error of the termination depth (``sum w t / sum w``) on the pixels in ``mask``."""
    if not mask.any():
        return float("nan")
    d = depth[mask] / np.maximum(opacity[mask], 1e-6)
    return float(np.mean(np.abs(d - gt[mask])))
