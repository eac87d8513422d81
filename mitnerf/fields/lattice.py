"""Lattices stored vertex-major (a record of floats a vertex, x fastest): the cell corners around points, reads of
records (in packets where they are padded to them), interpolation and resampling. The dense grid (:mod:`.grid`) and
the linearly decoded hash grid (:mod:`.hashlinear`) build on these; twin: :mod:`mitnerf.reference.fields.grid`."""

from __future__ import annotations

import drjit as dr
import numpy as np
from drjit.auto.ad import Array4f, ArrayXf, Float, Matrix4f, UInt32

from .base import cell_corners


PACKET_PAD = 0.25
"""A vertex's record of ``C`` floats is padded to whole packets of 16 floats, or else of 4, where that adds at most
this share of ``C`` (:func:`record_layout`): a packet is one read per corner where ``C`` floats are ``C`` reads, and
its gradient one scatter of a packet (``benchmarks/records.py`` measures what that buys a training step of the
grid's RGB view harmonics: 12 floats, no pad; 27 floats in 32)."""


def lattice_corners(x: list, bound: float, res: int):
    """``(integer coordinates, bi/trilinear weight)`` of the cell corners around points ``x`` (D arrays) on a
    lattice of ``res^D`` vertices over ``[-bound, bound]^D`` (vertex ``k`` at ``-bound + 2 bound k / (res - 1)``)."""
    return box_corners(x, [-bound] * len(x), [bound] * len(x), [res] * len(x))


def box_corners(x: list, lo: list, hi: list, shape: list):
    """:func:`lattice_corners` on a box: ``shape[a]`` vertices from ``lo[a]`` to ``hi[a]`` along axis ``a``."""
    u = []
    for xi, l, h, n in zip(x, lo, hi, shape):
        c, r = 0.5 * (l + h), 0.5 * (h - l)
        u.append(dr.clip(((xi if c == 0 else xi - c) * (1.0 / r) + 1.0) * (0.5 * (n - 1)), 0.0, n - 1.0001))
    i0 = [dr.floor(ui) for ui in u]
    return cell_corners([UInt32(f) for f in i0], [ui - f for ui, f in zip(u, i0)])


def strides(shape: list) -> list:
    """Flat-index step of each axis of a lattice stored x fastest."""
    return [int(np.prod(shape[:a])) for a in range(len(shape))]


def corner_weights(x: list, lo: list, hi: list, shape: list):
    """``([(flat index UInt32, bi/trilinear weight Float)] of the cell corners, inside Bool)`` of points ``x``
    (D arrays) in a lattice of ``shape`` vertices over the box ``lo``-``hi``; ``inside``: whether a point lies in it."""
    step = strides(shape)
    corners = [(sum((k * s for s, k in zip(step, key)), UInt32(0)), weight)
               for key, weight in box_corners(x, lo, hi, shape)]
    return corners, dr.all([(xi >= l) & (xi <= h) for xi, l, h in zip(x, lo, hi)])


def record_layout(channels: int) -> tuple[int, int]:
    """``(floats a record of channels takes in memory, floats a read takes)``: padded to whole packets of 16 floats,
    or else of 4, where that adds at most :data:`PACKET_PAD` of ``channels`` (27: (32, 16); 15: (16, 16); 12: (12,
    4)), else the floats alone, read one by one (3: (3, 1))."""
    for packet in (16, 4):
        padded = -(-channels // packet) * packet
        if padded - channels <= PACKET_PAD * channels:
            return padded, packet
    return channels, 1


def read_record(grid: Float, channels: int, index: UInt32, active=True, layout: tuple | None = None) -> list:
    """The first ``channels`` floats of the records at ``index`` of a grid stored vertex-major, its records laid out
    as ``layout`` says (:func:`record_layout`; None: ``channels`` floats, read one by one); where ``active`` is
    False, nothing is read (and 0 returned)."""
    stride, packet = layout or (channels, 1)
    if packet == 1:
        return [dr.gather(Float, grid, index * stride + c, active) for c in range(channels)]
    kind = {4: Array4f, 16: Matrix4f}[packet]
    values = []
    for j in range(-(-channels // packet)):
        v = dr.gather(kind, grid, index * (stride // packet) + j, active)
        values += [v[i][k] for i in range(4) for k in range(4)] if packet == 16 else list(v)
    return values[:channels]


def interpolate(grid: Float, channels: int, corners, active=True, layout: tuple | None = None) -> list:
    """Interpolated values of a grid stored vertex-major (``channels`` floats per vertex, in records laid out as
    ``layout`` says: :func:`read_record`); where ``active`` is False, nothing is read (and 0 returned)."""
    out = [Float(0.0)] * channels
    for index, weight in corners:
        for c, value in enumerate(read_record(grid, channels, index, active, layout)):
            out[c] = dr.fma(value, weight, out[c])
    return out


def lattice_points(extent: tuple, shape: list) -> np.ndarray:
    """The vertices of a lattice of ``shape`` over the box ``extent`` in storage order (x fastest): ``[V, D]``
    float32 (both engines' :func:`resample`)."""
    axes = [np.linspace(l, h, n, dtype=np.float32) for l, h, n in zip(*extent, shape)]
    return np.stack([v.ravel() for v in np.meshgrid(*axes[::-1], indexing="ij")[::-1]], 1)


def resample(grid: Float, channels: int, extent: tuple, shape: list, new_shape: list, layout: tuple | None = None
             ) -> Float:
    """A lattice of ``shape`` vertices over the box ``extent`` (stored vertex-major, ``channels`` floats a vertex,
    read as ``layout`` says: :func:`read_record`) interpolated at the vertices of a lattice of ``new_shape`` over the
    same box."""
    pts = lattice_points(extent, new_shape)
    corners, _ = corner_weights([Float(np.ascontiguousarray(c)) for c in pts.T], *extent, shape)
    return dr.ravel(ArrayXf(interpolate(grid, channels, corners, True, layout)))
