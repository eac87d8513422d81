"""Twin of :mod:`mitnerf.render.occupancy` (the same cells, jitter, thresholds and placement)."""

from __future__ import annotations

import numpy as np
import torch

from ...render.occupancy import OccupancyConfig
from ...render.space import Space, to_s, to_t
from ...rng import uniform_np
from .samplers import Explicit, column, offsets
from .volume import warp


def cell_index(x: torch.Tensor, bound: float, res: int):
    """``x [m, D]`` -> flat cell index [m], inside [m]."""
    u = (x / bound + 1.0) * (0.5 * res)
    inside = ((u >= 0) & (u < res)).all(dim=1)
    cell = torch.clamp(u, 0.0, res - 1.0).long()
    stride = res ** torch.arange(x.shape[1])
    return (cell * stride).sum(1), inside


class OccupancyGrid:
    def __init__(self, cfg: OccupancyConfig, dim: int, bound: float):
        self.cfg, self.dim, self.bound = cfg, dim, bound
        n = cfg.resolution ** dim
        self.value = torch.zeros(n)
        self.occupied = torch.ones(n)

    def cell_centres(self, jitter: int | None = None) -> torch.Tensor:
        res = self.cfg.resolution
        idx = np.arange(res ** self.dim, dtype=np.uint32)
        cols = []
        for a in range(self.dim):
            c = ((idx // res ** a) % res).astype(np.float32)
            off = np.float32(0.5) if jitter is None else uniform_np(jitter, idx, np.full(idx.shape, a, np.uint32))
            cols.append(((c + off) * np.float32(2.0 / res) - np.float32(1.0)) * np.float32(self.bound))
        return torch.from_numpy(np.stack(cols, 1).astype(np.float32))

    def update(self, density_fn, step: int, seed: int) -> None:
        if step < self.cfg.warmup:
            return
        with torch.no_grad():
            sigma = density_fn(self.cell_centres(jitter=seed))
            self.value = torch.maximum(self.value * self.cfg.decay, sigma)
            level = torch.clamp(self.value.mean(), max=self.cfg.threshold)
            self.occupied = (self.value > level).float()

    def state(self) -> dict:
        return {"value": self.value.numpy(), "occupied": self.occupied.numpy()}

    def load(self, state: dict) -> None:
        self.value = torch.as_tensor(np.asarray(state["value"], np.float32))
        self.occupied = torch.as_tensor(np.asarray(state["occupied"], np.float32))


def occupied_samples(grid: OccupancyGrid, origins, directions, near, far, n: int, seed: int, jitter: bool,
                     space: Space = Space(), density=None, early_stop: float = 0.0) -> Explicit:
    """Twin of ``OccupiedSampler.build``: ``origins, directions [n_rays, D]``; ``density(x [m, D]) -> [m]``, the
    field's, with ``early_stop`` (``OccupiedSampler.early_stop``)."""
    bins = grid.cfg.march_bins
    n_rays = origins.shape[0]
    near, far = column(near).expand(n_rays, 1), column(far).expand(n_rays, 1)
    dt = (far - near) * (1.0 / bins)
    if space.knee is not None:                 # bins even in the spacing (``_at`` of the Dr.Jit sampler)
        lo, hi = (to_s(v, space.knee, torch.where) for v in (near, far))
        at = lambda k, lo, hi: to_t(lo + k * ((hi - lo) * (1.0 / bins)), space.knee, torch.where)  # noqa: E731
    mid = torch.arange(bins, dtype=torch.float32) + 0.5
    t_mid = near + mid * dt if space.knee is None else at(mid, lo, hi)                       # [n_rays, M]
    x = origins[:, None, :] + t_mid[..., None] * directions[:, None, :]
    x, stretch = warp(space, x, directions[:, None, :].expand_as(x))
    cell, inside = cell_index(x.reshape(-1, origins.shape[1]), grid.bound, grid.cfg.resolution)
    occ = (inside & (grid.occupied[cell] > 0.5)).reshape(n_rays, bins)
    if density is not None and early_stop > 0.0:       # the bins a march takes while its transmittance lasts
        if space.knee is None:
            width = dt
        else:
            edges = at(torch.arange(bins + 1, dtype=torch.float32), lo, hi)
            width = edges[:, 1:] - edges[:, :-1]
        width = width if stretch is None else width * stretch      # density per unit of distance, as rendered
        with torch.no_grad():
            sigma = density(x.reshape(-1, origins.shape[1])).reshape(n_rays, bins)
        depth = torch.where(occ, sigma.clamp(min=0.0) * width, 0.0)                  # each bin's optical depth
        occ = occ & (torch.cumsum(depth, 1) - depth < float(-np.log(early_stop)))      # the depth in front of it
    K = occ.sum(1, keepdim=True)
    stride = torch.clamp((K + (n - 1)) // n, min=1)
    rank = torch.cumsum(occ.long(), 1) - occ.long()                               # occupied bins before
    j = rank // stride
    r_idx, k_idx = torch.nonzero(occ & (rank % stride == 0) & (j < n), as_tuple=True)
    u = offsets(seed, n_rays, bins, jitter)
    t_out, d_out = far.expand(n_rays, n).clone(), torch.zeros(n_rays, n)
    slot, group = j[r_idx, k_idx], torch.minimum(stride, K - rank)[r_idx, k_idx].float()
    if space.knee is None:
        t_out[r_idx, slot] = near[r_idx, 0] + (k_idx.float() + u[r_idx, k_idx]) * dt[r_idx, 0]
        d_out[r_idx, slot] = group * dt[r_idx, 0]
    else:
        ends = (lo[r_idx, 0], hi[r_idx, 0])
        t_out[r_idx, slot] = at(k_idx.float() + u[r_idx, k_idx], *ends)
        d_out[r_idx, slot] = at(k_idx.float() + group, *ends) - at(k_idx.float(), *ends)
    return Explicit(t_out, n, d_out)
