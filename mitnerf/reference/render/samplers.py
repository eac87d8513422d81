"""Twin of :mod:`mitnerf.render.samplers`: the same sample positions, bit for bit in the
hash (:mod:`mitnerf.rng`, numpy uint32, whose multiplication wraps like Dr.Jit's UInt32)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ...render.space import to_s, to_t
from ...rng import uniform_np


def column(value) -> torch.Tensor:
    """Per-ray values ``[n_rays]`` or a scalar as a float32 column ``[n_rays or 1, 1]``."""
    return torch.as_tensor(value, dtype=torch.float32).reshape(-1, 1)


def offsets(seed: int, n_rays: int, n: int, jitter: bool) -> torch.Tensor:
    """``[n_rays, n]``: the hash ``uniform(seed, ray, i)`` of :mod:`mitnerf.rng`, or 0.5 without jitter."""
    if not jitter:
        return torch.full((n_rays, n), 0.5, dtype=torch.float32)
    ray, i = np.meshgrid(np.arange(n_rays, dtype=np.uint32), np.arange(n, dtype=np.uint32), indexing="ij")
    return torch.from_numpy(uniform_np(seed, ray, i))


@dataclass
class Stratified:
    n: int
    seed: int
    jitter: bool = True
    knee: float | None = None

    def points(self, n_rays: int, near: torch.Tensor, far: torch.Tensor):
        """``t, delta [n_rays, n]`` (``near, far``: ``[n_rays]`` or scalars)."""
        near, far = column(near), column(far)
        i = torch.arange(self.n + 1, dtype=torch.float32)
        u = i + offsets(self.seed, n_rays, self.n + 1, self.jitter)
        if self.knee is None:
            t = near + u * ((far - near) * (1.0 / self.n))
        else:
            lo, hi = (to_s(v, self.knee, torch.where) for v in (near, far))
            t = to_t(lo + u * ((hi - lo) * (1.0 / self.n)), self.knee, torch.where)
        t[:, self.n:] = far.expand(n_rays, 1)
        return t[:, :-1], t[:, 1:] - t[:, :-1]


@dataclass
class Explicit:
    t: torch.Tensor   # [n_rays, n]
    n: int
    delta: torch.Tensor | None = None   # [n_rays, n]; None: contiguous

    def points(self, n_rays, near, far):
        if self.delta is not None:
            return self.t, self.delta
        return self.t, torch.cat([self.t[:, 1:], column(far).expand(n_rays, 1)], dim=1) - self.t


def importance_sample(t, delta, weights, n_fine: int, seed: int, jitter: bool) -> Explicit:
    """Twin of :func:`mitnerf.render.samplers.importance_sample` (``[n_rays, n_coarse]`` inputs)."""
    n_rays, Nc = t.shape
    w = weights.detach() + 1e-5
    cdf = torch.cumsum(w, dim=1)
    j = torch.arange(n_fine, dtype=torch.float32)
    target = (j + offsets(seed ^ 0x5BD1E995, n_rays, n_fine, jitter)) * (1.0 / n_fine) * cdf[:, -1:]
    k = torch.clamp(torch.searchsorted(cdf, target, right=False), max=Nc - 1)
    wk = torch.gather(w, 1, k)
    frac = torch.clamp((target - (torch.gather(cdf, 1, k) - wk)) / wk, 0.0, 1.0)
    t_new = torch.gather(t, 1, k) + frac * torch.gather(delta, 1, k)
    merged, _ = torch.sort(torch.cat([t.detach(), t_new], dim=1), dim=1, stable=True)
    return Explicit(merged, Nc + n_fine)
