"""The multi-resolution hash encoding, functional and with scalar gathers.

It computes what ``drjit.nn.HashGridEncoding`` (``align_corners=False``) computes from
the same table, up to fp32 rounding (the tests compare them): the same level scales (``2^(l log2 s) base - 1``) and
resolutions (``ceil(scale) + 1``), dense indexing while a level's ``res^D`` vertices
fit its share of the table and the XOR-of-primes hash beyond, positions offset by
half a cell, and ``F`` consecutive features per table entry. The table is a
parameter passed in (structure apart from storage), and every lookup is a scalar
``dr.gather``: a training step built on it can be recorded with ``dr.freeze``, which
Dr.Jit 1.5.0 cannot do for ``HashGridEncoding`` followed by a network (the second
recording aborts with "enqueue_host_func(): this function cannot be recorded").
Twin: :mod:`mitnerf.reference.fields.hashenc`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import drjit as dr
from drjit.auto.ad import Float, UInt32

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
    log2_scale = dr.log2(float(per_level_scale))     # Dr.Jit's scalar functions, as the encoding:
    scales, res, offsets, sizes, dense = [], [], [], [], []     # Python's 2.0 ** x can round a
    offset = 0                                                  # scale across an integer (26 vs 26.000..04)
    for level in range(n_levels):
        scale = float(dr.exp2(level * log2_scale)) * base_resolution - 1.0
        r = int(math.ceil(scale)) + 1
        n = min(-(-r ** dim // features) * features, hashmap_size)
        scales.append(scale)
        res.append(r)
        offsets.append(offset)
        sizes.append(n)
        dense.append(r ** dim <= n)
        offset += n
    return HashLayout(dim, features, tuple(scales), tuple(res), tuple(offsets), tuple(sizes), tuple(dense))


def _entry(key: list, level: int, layout: HashLayout) -> UInt32:
    r, n = layout.resolutions[level], layout.sizes[level]
    if layout.dense[level]:
        index, stride = UInt32(0), 1
        for k in key:
            index += k * stride
            stride *= r
    else:
        index = UInt32(0)
        for d, k in enumerate(key):
            index ^= k * PRIMES[d]
    return layout.offsets[level] + index % n


def hash_encode(table: Float, x: list, layout: HashLayout) -> list:
    """Features of points ``x`` (D arrays ``[n]`` in [0, 1]); ``n_levels * F`` arrays,
    level-major (level ``l``, feature ``k`` at ``l * F + k``)."""
    F = layout.features
    out = []
    for level in range(layout.n_levels):
        pos = [xi * layout.scales[level] + 0.5 for xi in x]
        p0 = [UInt32(dr.floor(p)) for p in pos]
        w1 = [p - dr.floor(p) for p in pos]
        acc = [Float(0.0)] * F
        for corner in range(1 << layout.dim):
            key, weight = [], Float(1.0)
            for d in range(layout.dim):
                bit = (corner >> d) & 1
                key.append(p0[d] + bit)
                weight = weight * (w1[d] if bit else 1.0 - w1[d])
            base = _entry(key, level, layout) * F
            for k in range(F):
                acc[k] = dr.fma(dr.gather(Float, table, base + k), weight, acc[k])
        out += acc
    return out
