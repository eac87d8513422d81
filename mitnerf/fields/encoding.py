"""Encodings of positions and view directions (Dr.Jit; twin: ``mitnerf.reference.fields.encoding``).

Feature order is part of the contract with the PyTorch twin (weights are copied
between them), so both compute exactly the same list in the same order.
"""

from __future__ import annotations

import math

import drjit as dr


def positional_encoding(x: list, L: int, opened=None) -> list:
    """NeRF's gamma: ``[x_j] + [sin(2^k pi x_j)]_j + [cos(2^k pi x_j)]_j`` for k < L, ``D * (1 + 2 L)`` arrays
    ``[n]`` of D arrays ``x`` ``[n]`` (normalised, about [-1, 1]); ``L = 0``: the raw coordinates. ``opened``: how
    many frequencies are let through (a Float, FreeNeRF's window): band k is scaled by ``clip(opened - k, 0, 1)``;
    None: all of them."""
    out = list(x)
    for k in range(L):
        sc = [dr.sincos(xi * float(2.0 ** k * math.pi)) for xi in x]
        if opened is None:
            out += [s for s, _ in sc] + [c for _, c in sc]
        else:
            w = dr.clip(opened - k, 0.0, 1.0)
            out += [s * w for s, _ in sc] + [c * w for _, c in sc]
    return out


def angle_harmonics(d: list, L: int) -> list:
    """2D view direction ``d = (cos t, sin t)`` -> ``[cos m t, sin m t]`` for m = 1, 2, 4, .., 2^(L-1) (``2 L``
    arrays), by the double-angle formulas (no atan2, smooth in d)."""
    out, c, s = [], d[0], d[1]
    for k in range(L):
        if k:
            c, s = c * c - s * s, 2.0 * s * c
        out += [c, s]
    return out


def direction_encoding(d: list, L: int) -> list:
    """View-direction features: angle harmonics in 2D, gamma of the unit vector in 3D."""
    return angle_harmonics(d, L) if len(d) == 2 else positional_encoding(d, L)


def encoded_size(dim: int, L: int, direction: bool = False) -> int:
    return 2 * L if direction and dim == 2 else dim * (1 + 2 * L)
