"""Twin of :mod:`mitnerf.train.losses`."""

from __future__ import annotations

import math

import torch

EPS = 1e-5


def distortion(weights, t, delta, N: int) -> torch.Tensor:
    """``[n_rays, N]`` inputs (sorted per ray)."""
    m = t + 0.5 * delta
    W = torch.cumsum(weights, 1) - weights
    S = torch.cumsum(weights * m, 1) - weights * m
    return (2.0 * weights * (m * W - S) + (1.0 / 3.0) * weights ** 2 * delta).sum(1).mean()


def opacity_entropy(opacity: torch.Tensor) -> torch.Tensor:
    a = torch.clamp(opacity, 1e-4, 1.0 - 1e-4)
    return (-(a * torch.log(a) + (1.0 - a) * torch.log(1.0 - a))).mean()


def mse(rgb: torch.Tensor, target: torch.Tensor, weight: torch.Tensor | None = None) -> torch.Tensor:
    """``rgb, target [n_rays, 3]``, ``weight [n_rays]`` (None: 1)."""
    sq = (rgb - target) ** 2
    return torch.mean(sq if weight is None else sq * weight[:, None])


def rms_error(rgb: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """``[n_rays]``, without gradients."""
    return torch.sqrt(torch.mean((rgb.detach() - target) ** 2, 1))


def depth_kl(weights, t, delta, depth, hit, N: int, sigma: float) -> torch.Tensor:
    """``weights, t, delta [n_rays, N]``, ``depth, hit [n_rays]`` (``N`` as in the Dr.Jit signature)."""
    z = (t - depth[:, None]) / sigma
    log_q = -0.5 * z * z - math.log(sigma * math.sqrt(2.0 * math.pi))
    safe = torch.clamp(delta, min=1e-12)
    term = torch.exp(log_q) * delta * (log_q - torch.log(weights / safe + EPS))
    per_ray = torch.where(delta > 0, term, torch.zeros_like(term)).sum(1) * hit
    return per_ray.sum() / torch.clamp(hit.sum(), min=1.0)


def free_space(weights, t, delta, free, N: int, margin: float) -> torch.Tensor:
    """``weights, t, delta [n_rays, N]``, ``free [n_rays]`` (``N`` as in the Dr.Jit signature)."""
    before = (t + delta <= free[:, None] - margin) & (delta > 0)
    per_ray = torch.where(before, weights, torch.zeros_like(weights)).sum(1)
    known = (free > 0).to(weights.dtype)
    return (per_ray * known).sum() / torch.clamp(known.sum(), min=1.0)


def solid_behind(sigma, hit, level: float) -> torch.Tensor:
    """``sigma, hit [n_rays]``."""
    short = torch.clamp(1.0 - sigma / level, min=0.0)
    return (short * short * hit).sum() / torch.clamp(hit.sum(), min=1.0)
