"""Twin of :mod:`mitnerf.render.samplers`: the same sample positions, bit for bit in the
hash (:mod:`mitnerf.rng`, numpy uint32, whose multiplication wraps like Dr.Jit's UInt32)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ...rng import uniform_np as uniform


@dataclass
class Stratified:
    n: int
    seed: int
    jitter: bool = True

    def points(self, n_rays: int, near: torch.Tensor, far: torch.Tensor):
        """``t, delta [n_rays, n]`` (``near, far``: ``[n_rays]`` or scalars)."""
        ray = np.repeat(np.arange(n_rays, dtype=np.uint32), self.n + 1).reshape(n_rays, self.n + 1)
        i = np.tile(np.arange(self.n + 1, dtype=np.uint32), (n_rays, 1))
        u = uniform(self.seed, ray, i) if self.jitter else np.full(ray.shape, 0.5, np.float32)
        near = torch.as_tensor(near, dtype=torch.float32).reshape(-1, 1)
        far = torch.as_tensor(far, dtype=torch.float32).reshape(-1, 1)
        t = near + (torch.from_numpy(i.astype(np.float32)) + torch.from_numpy(u)) * ((far - near) * (1.0 / self.n))
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
        far = torch.as_tensor(far, dtype=torch.float32).reshape(-1, 1).expand(n_rays, 1)
        return self.t, torch.cat([self.t[:, 1:], far], dim=1) - self.t


def importance_sample(t, delta, weights, n_fine: int, seed: int, jitter: bool) -> Explicit:
    """Twin of :func:`mitnerf.render.samplers.importance_sample` (``[n_rays, n_coarse]`` inputs)."""
    n_rays, Nc = t.shape
    w = weights.detach() + 1e-5
    cdf = torch.cumsum(w, dim=1)
    j = np.tile(np.arange(n_fine, dtype=np.uint32), (n_rays, 1))
    ray = np.repeat(np.arange(n_rays, dtype=np.uint32), n_fine).reshape(n_rays, n_fine)
    u = uniform(seed ^ 0x5BD1E995, ray, j) if jitter else np.full(j.shape, 0.5, np.float32)
    u = (torch.from_numpy(j.astype(np.float32)) + torch.from_numpy(u)) * (1.0 / n_fine)
    target = u * cdf[:, -1:]
    k = torch.clamp(torch.searchsorted(cdf, target, right=False), max=Nc - 1)
    wk = torch.gather(w, 1, k)
    frac = torch.clamp((target - (torch.gather(cdf, 1, k) - wk)) / wk, 0.0, 1.0)
    t_new = torch.gather(t, 1, k) + frac * torch.gather(delta, 1, k)
    merged, _ = torch.sort(torch.cat([t.detach(), t_new], dim=1), dim=1, stable=True)
    return Explicit(merged, Nc + n_fine)
