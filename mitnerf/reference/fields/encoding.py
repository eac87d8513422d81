"""Twin of :mod:`mitnerf.fields.encoding` (same features, same order)."""

from __future__ import annotations

import math

import torch


def positional_encoding(x: torch.Tensor, L: int, opened: float | None = None) -> torch.Tensor:
    """``x [n, D]`` -> ``[n, D (1 + 2 L)]``: x, then sin and cos of 2^k pi x per k, band k scaled by
    ``clip(opened - k, 0, 1)`` when ``opened`` is given."""
    a = [x * float(2.0 ** k * math.pi) for k in range(L)]
    w = [1.0 if opened is None else min(max(opened - k, 0.0), 1.0) for k in range(L)]
    return torch.cat([x] + [f(ak) * wk for ak, wk in zip(a, w) for f in (torch.sin, torch.cos)], dim=-1)


def angle_harmonics(d: torch.Tensor, L: int) -> torch.Tensor:
    """``d [n, 2]`` unit vectors -> ``[n, 2 L]``: cos/sin of 1, 2, 4, .. times the angle."""
    if L == 0:
        return d[:, :0]
    c, s = d[:, 0], d[:, 1]
    out = [c, s]
    for _ in range(1, L):
        c, s = c * c - s * s, 2.0 * s * c
        out += [c, s]
    return torch.stack(out, dim=-1)


def direction_encoding(d: torch.Tensor, L: int) -> torch.Tensor:
    return angle_harmonics(d, L) if d.shape[-1] == 2 else positional_encoding(d, L)
