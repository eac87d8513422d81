"""Twin of :mod:`mitnerf.render.volume`: the volume integral in PyTorch autograd (exclusive cumulative sums)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import torch

from ...render.integral import W_MIN
from ...render.space import Ops, Space

TORCH = Ops(torch.sqrt, lambda a, c: torch.clamp(a, max=c), torch.where)


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


def warp(space: Space, x: torch.Tensor, d: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor | None]:
    """``x, d [..., 3]`` -> the field's points ``[..., 3]`` and the density stretch ``[...]`` (None: no warp)."""
    if not space.warped:
        return x, None
    xw, stretch = space.warp(list(x.unbind(-1)), list(d.unbind(-1)), TORCH)
    return torch.stack(xw, -1), stretch


def volume_render(field, origins, directions, near, far, sampler, background=(0.0, 0.0, 0.0),
                  weights: bool = False, w_min: float = W_MIN, space: Space = Space()) -> RenderOutput:
    """``origins, directions [n_rays, D]`` -> :class:`RenderOutput`."""
    n, D = origins.shape
    t, delta = sampler.points(n, near, far)
    N = t.shape[1]
    x = origins[:, None, :] + t[..., None] * directions[:, None, :]
    dirs = directions[:, None, :].expand(n, N, D)
    x, stretch = warp(space, x, dirs)
    sigma, rgb = field.query(x.reshape(-1, D), dirs.reshape(-1, D))
    sigma = sigma if stretch is None else sigma * stretch.reshape(-1)
    out = integrate(sigma.reshape(n, N), rgb.reshape(n, N, 3), t, delta, background, w_min)
    return out if weights else replace(out, weights=None)
