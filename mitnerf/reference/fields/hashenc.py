"""Twin of :mod:`mitnerf.fields.hashenc` (the same layout, indices and interpolation)."""

from __future__ import annotations

import torch

from ...fields.base import cell_corners
from ...fields.hashenc import PRIMES, HashLayout


def vertex_entry(key: list, level: int, layout) -> torch.Tensor:
    """Twin of :func:`mitnerf.fields.hashenc.vertex_entry` (uint32 arithmetic in int64)."""
    mask, res, index = 0xFFFFFFFF, layout.resolutions[level], torch.zeros_like(key[0])
    for d, k in enumerate(key):
        if layout.dense[level]:
            index = (index + k * res ** d) & mask
        else:
            index = index ^ ((k * PRIMES[d]) & mask)     # uint32 multiply, in int64
    return index % layout.sizes[level]


def hash_encode(table: torch.Tensor, x: torch.Tensor, layout: HashLayout) -> torch.Tensor:
    """``x [n, D]`` in [0, 1] -> ``[n, n_levels * F]`` (level-major)."""
    F = layout.features
    out = []
    for level in range(layout.n_levels):
        pos = x * layout.scales[level] + 0.5
        p0 = torch.floor(pos)
        acc = 0.0
        for key, weight in cell_corners(list(p0.long().unbind(1)), list((pos - p0).unbind(1))):
            base = (layout.offsets[level] + vertex_entry(key, level, layout)) * F
            acc = acc + torch.stack([table[base + k] for k in range(F)], 1) * weight[:, None]
        out.append(acc)
    return torch.cat(out, dim=1)
