"""Twin of :mod:`mitnerf.fields.hashenc` (the same layout, indices and interpolation)."""

from __future__ import annotations

import torch

from ...fields.hashenc import PRIMES, HashLayout


def _entry(key: list, level: int, layout: HashLayout) -> torch.Tensor:
    r, n = layout.resolutions[level], layout.sizes[level]
    mask = 0xFFFFFFFF
    if layout.dense[level]:
        index, stride = torch.zeros_like(key[0]), 1
        for k in key:
            index = (index + k * stride) & mask
            stride *= r
    else:
        index = torch.zeros_like(key[0])
        for d, k in enumerate(key):
            index = index ^ ((k * PRIMES[d]) & mask)     # uint32 multiply, in int64
    return layout.offsets[level] + index % n


def hash_encode(table: torch.Tensor, x: torch.Tensor, layout: HashLayout) -> torch.Tensor:
    """``x [n, D]`` in [0, 1] -> ``[n, n_levels * F]`` (level-major)."""
    F = layout.features
    out = []
    for level in range(layout.n_levels):
        pos = x * layout.scales[level] + 0.5
        p0 = torch.floor(pos)
        w1 = pos - p0
        p0 = p0.long()
        acc = 0.0
        for corner in range(1 << layout.dim):
            key, weight = [], torch.ones_like(x[:, 0])
            for d in range(layout.dim):
                bit = (corner >> d) & 1
                key.append(p0[:, d] + bit)
                weight = weight * (w1[:, d] if bit else 1.0 - w1[:, d])
            base = _entry(key, level, layout) * F
            acc = acc + torch.stack([table[base + k] for k in range(F)], 1) * weight[:, None]
        out.append(acc)
    return torch.cat(out, dim=1)
