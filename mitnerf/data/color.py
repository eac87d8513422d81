"""sRGB encoding (IEC 61966-2-1), numpy, elementwise."""

from __future__ import annotations

import numpy as np


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055).astype(np.float32)


def to_uint8(x: np.ndarray) -> np.ndarray:
    return (np.clip(x, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def display_color(linear: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Display-space colour premultiplied by coverage, from linear colour over black (``linear [..., 3]``,
    ``alpha [...]``): the straight colour sRGB-encoded, times alpha (as a straight-alpha sRGB PNG composited in
    display space), so ``color + (1 - alpha) * background`` stays within [0, 1]."""
    a = np.asarray(alpha, np.float32)[..., None]
    straight = np.where(a > 0, np.asarray(linear) / np.maximum(a, 1e-8), 0.0)
    return (linear_to_srgb(straight) * a).astype(np.float32)
