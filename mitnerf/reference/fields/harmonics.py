"""Twin of :mod:`mitnerf.fields.harmonics`: view harmonics on torch tensors."""

from __future__ import annotations

import torch

from ...fields.harmonics import view_basis


def harmonic_rgb(raw: torch.Tensor, d: torch.Tensor, degree: int, grey: bool = False) -> torch.Tensor:
    """``raw [n, 3, K]`` colour coefficients at unit directions ``d [n, D]`` -> RGB ``[n, 3]``; ``grey``: ``raw
    [n, 3 + K - 1]``, each channel's degree-0 term, then the harmonics above it that all three share."""
    if grey or raw.shape[-1] > 1:
        basis = torch.stack(view_basis(list(d.unbind(1)), degree), 1)    # [n, K]
        if grey:
            return torch.sigmoid(raw[:, :3] + (raw[:, 3:] * basis[:, 1:]).sum(1, keepdim=True))
        raw = raw * basis[:, None, :]
    return torch.sigmoid(raw.sum(-1))
