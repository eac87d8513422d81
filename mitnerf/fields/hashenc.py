"""The multi-resolution hash encoding, functional and with scalar gathers.

It computes what ``drjit.nn.HashGridEncoding`` (``align_corners=False``) computes from the same
table, up to fp32 rounding: the same level scales and resolutions, dense indexing while a level's
``res^D`` vertices fit its share of the table and the XOR-of-primes hash beyond, positions offset
by half a cell, ``F`` consecutive features per entry. The table is a parameter and every lookup a
scalar ``dr.gather``, so a training step can be recorded with ``dr.freeze`` (through ``HashGridEncoding``
it cannot: :mod:`mitnerf._drjit_compat`). Twin: :mod:`mitnerf.reference.fields.hashenc`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import drjit as dr
from drjit.auto.ad import Float, UInt32

from .base import cell_corners

PRIMES = (1, 2654435761, 805459861, 3674653429, 2097192037, 1434869437, 2165219737)


@dataclass(frozen=True)
class HashLayout:
    """Where each level lives in the table."""

    dim: int
    features: int
    scales: tuple
    resolutions: tuple
    offsets: tuple        # first entry of each level (entries, not floats)
    sizes: tuple          # entries of each level
    dense: tuple          # whether a level is indexed densely

    @property
    def n_levels(self) -> int:
        return len(self.scales)

    @property
    def n_params(self) -> int:
        return (self.offsets[-1] + self.sizes[-1]) * self.features


def hash_layout(dim: int, n_levels: int, features: int, hashmap_size: int, base_resolution: int,
                per_level_scale: float) -> HashLayout:
    # Dr.Jit's scalar functions, as the encoding (Python's 2.0 ** x can round 26 to 26.000..04)
    log2_scale = dr.log2(float(per_level_scale))
    scales = [float(dr.exp2(level * log2_scale)) * base_resolution - 1.0 for level in range(n_levels)]
    res = [int(math.ceil(scale)) + 1 for scale in scales]
    sizes = [min(-(-r ** dim // features) * features, hashmap_size) for r in res]
    offsets = [sum(sizes[:level]) for level in range(n_levels)]
    return HashLayout(dim, features, tuple(scales), tuple(res), tuple(offsets), tuple(sizes),
                      tuple(r ** dim <= n for r, n in zip(res, sizes)))


def vertex_entry(key: list, level: int, layout) -> UInt32:
    """Entry of the vertex at integer coordinates ``key`` within ``level`` of ``layout`` (a :class:`HashLayout` or
    a :class:`~.hashlinear.Levels`): its row-major index where the level is stored densely, else the XOR-of-primes
    hash, modulo the level's entries."""
    res, index = layout.resolutions[level], UInt32(0)
    for d, k in enumerate(key):
        index = index + k * res ** d if layout.dense[level] else index ^ k * PRIMES[d]
    return index % layout.sizes[level]


def hash_encode(table: Float, x: list, layout: HashLayout) -> list:
    """Features of points ``x`` (D arrays ``[n]`` in [0, 1]); ``n_levels * F`` arrays,
    level-major (level ``l``, feature ``k`` at ``l * F + k``)."""
    F = layout.features
    out = []
    for level in range(layout.n_levels):
        pos = [xi * layout.scales[level] + 0.5 for xi in x]
        acc = [Float(0.0)] * F
        for key, weight in cell_corners([UInt32(dr.floor(p)) for p in pos], [p - dr.floor(p) for p in pos]):
            base = (layout.offsets[level] + vertex_entry(key, level, layout)) * F
            for k in range(F):
                acc[k] = dr.fma(dr.gather(Float, table, base + k), weight, acc[k])
        out += acc
    return out
