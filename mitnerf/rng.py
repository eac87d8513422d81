"""Counter-based random numbers shared by both backends (no torch, no state): every random choice (batch
pixels, sample jitter) is a hash of integers, so Dr.Jit kernels and their numpy twins draw the same numbers."""

from __future__ import annotations

import numpy as np


def hash_u32(x):
    """Wellons' lowbias32 integer hash (bijective on 32-bit integers), of numpy ``uint32`` arrays
    or Dr.Jit ``UInt32`` alike."""
    if isinstance(x, (np.ndarray, np.generic)):
        x = x.astype(np.uint32)
    with np.errstate(over="ignore"):
        x = x ^ (x >> 16)
        x = x * 0x7FEB352D
        x = x ^ (x >> 15)
        x = x * 0x846CA68B
        return x ^ (x >> 16)


def uniform(seed, ray, i):
    """Dr.Jit: a uniform number in [0, 1) for (seed, ray, i), 24 random bits."""
    from drjit.auto.ad import Float

    h = hash_u32(hash_u32(hash_u32(seed) ^ ray) ^ (i * 0x9E3779B9))
    return Float(h >> 8) * (1.0 / 16777216.0)


def uniform_np(seed: int, ray: np.ndarray, i: np.ndarray) -> np.ndarray:
    """numpy twin of :func:`uniform` (float32, the same bits)."""
    with np.errstate(over="ignore"):
        h = hash_u32(hash_u32(hash_u32(np.uint32(seed)) ^ ray.astype(np.uint32))
                     ^ (i.astype(np.uint32) * np.uint32(0x9E3779B9)))
    return (h >> np.uint32(8)).astype(np.float32) * np.float32(1.0 / 16777216.0)


def step_seed(seed: int, step: int) -> int:
    """The 32-bit seed of training step ``step`` (batch choice and sample jitter)."""
    with np.errstate(over="ignore"):
        return int(hash_u32(np.uint32(seed) * np.uint32(0x01000193) ^ np.uint32(step)))


def batch_indices(seed: int, batch: int, n_pixels: int) -> np.ndarray:
    """The pixels of one batch, ``[batch]`` int64 (numpy twin of the in-kernel choice)."""
    with np.errstate(over="ignore"):
        h = hash_u32(hash_u32(np.uint32(seed)) ^ np.arange(batch, dtype=np.uint32))
    return (h % np.uint32(n_pixels)).astype(np.int64)
