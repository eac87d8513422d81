"""Twin of :mod:`mitnerf.render.volume`: the volume integral in PyTorch autograd (exclusive cumulative sums)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import torch

from ...render.integral import W_MIN


@dataclass
class RenderOutput:
    rgb: torch.Tensor       # [n_rays, 3]
    depth: torch.Tensor     # [n_rays]
    opacity: torch.Tensor   # [n_rays]
    weights: torch.Tensor | None = None   # [n_rays, N]


def integrate(sigma, rgb, t, delta, background, w_min: float = W_MIN) -> RenderOutput:
    """``sigma, t, delta [n_rays, N]``, ``rgb [n_rays, N, 3]``; samples of weight at most ``w_min`` add no colour."""
    sd = sigma * delta
    cum = torch.cumsum(sd, dim=1)
    T = torch.exp(-torch.cat([torch.zeros_like(cum[:, :1]), cum[:, :-1]], dim=1))
    w = T * (1.0 - torch.exp(-sd))
    T_end = torch.exp(-cum[:, -1])
    bg = torch.as_tensor(background, dtype=rgb.dtype)
    C = torch.where((w > w_min)[..., None], w[..., None] * rgb, 0.0).sum(1) + T_end[:, None] * bg
    return RenderOutput(C, (w * t).sum(1), 1.0 - T_end, w)


def volume_render(field, origins, directions, near, far, sampler, background=(0.0, 0.0, 0.0),
                  weights: bool = False, w_min: float = W_MIN) -> RenderOutput:
    """``origins, directions [n_rays, D]`` -> :class:`RenderOutput`."""
    n, D = origins.shape
    t, delta = sampler.points(n, near, far)
    N = t.shape[1]
    x = origins[:, None, :] + t[..., None] * directions[:, None, :]
    sigma, rgb = field.query(x.reshape(-1, D), directions[:, None, :].expand(n, N, D).reshape(-1, D))
    out = integrate(sigma.reshape(n, N), rgb.reshape(n, N, 3), t, delta, background, w_min)
    return out if weights else replace(out, weights=None)
