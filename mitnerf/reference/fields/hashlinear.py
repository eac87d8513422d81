"""Twin of :mod:`mitnerf.fields.hashlinear`: the same levels, entries, corner order, weights and sums (autograd)."""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from ...errors import CheckpointError
from ...fields.hashlinear import HashLinearConfig, levels_of
from .grid import lattice_corners, tv_vertices
from .harmonics import harmonic_rgb
from .hashenc import vertex_entry
from .mlp import TwinField, density_activation


class HashLinearField(TwinField):
    def __init__(self, cfg: HashLinearConfig):
        super().__init__(cfg)
        self.levels, self.K = levels_of(cfg), cfg.color_coeffs
        nd, nc = self.levels.widths(cfg.levels_at(0))
        self.density_table = nn.Parameter(torch.zeros(nd))
        self.color_table = nn.Parameter(torch.zeros(nc))

    @property
    def n_levels(self) -> int:
        return self.levels.in_use(self.density_table.shape[0])

    def load_numpy(self, arrays) -> None:
        d, c = (torch.as_tensor(np.asarray(arrays[k], np.float32).ravel()) for k in ("density", "color"))
        if (d.numel(), c.numel()) not in [self.levels.widths(n) for n in range(1, len(self.levels.sizes) + 1)]:
            raise CheckpointError("the tables fit no level count of this configuration")
        self.density_table, self.color_table = nn.Parameter(d), nn.Parameter(c)

    def to_numpy(self) -> dict:
        return {"density": self.density_table.detach().numpy().copy(), "color": self.color_table.detach().numpy().copy()}

    def schedule(self, step: int) -> bool:
        n = self.cfg.levels_at(step)
        if n == self.n_levels:
            return False
        nd, nc = self.levels.widths(n)
        with torch.no_grad():
            d = torch.cat([self.density_table, torch.zeros(nd - self.density_table.shape[0])])
            c = torch.cat([self.color_table, torch.zeros(nc - self.color_table.shape[0])])
        self.density_table, self.color_table = nn.Parameter(d), nn.Parameter(c)
        return True

    def corners(self, x: torch.Tensor, n: int) -> list:
        """``x [m, D]`` -> per level: ``[(entry [m], weight [m])]``."""
        return [[(vertex_entry(key, level, self.levels), w)
                 for key, w in lattice_corners(x, self.cfg.bound, self.levels.resolutions[level])]
                for level in range(n)]

    def raw_density(self, corners) -> torch.Tensor:
        return sum(self.density_table[self.levels.offsets[level] + e] * w
                   for level, cs in enumerate(corners) for e, w in cs)

    def raw_color(self, corners) -> torch.Tensor:
        """``[m, 3, K]`` summed colour coefficients."""
        K, lv, total = self.K, self.levels, 0.0
        for level, cs in enumerate(corners):
            k_l = lv.coeffs[level]
            idx = torch.arange(3 * k_l)
            for e, w in cs:
                v = self.color_table[lv.color_offsets[level] + e[:, None] * (3 * k_l) + idx].reshape(-1, 3, k_l)
                total = total + torch.nn.functional.pad(v, (0, K - k_l)) * w[:, None, None]
        return total

    def _sigma(self, x):
        corners = self.corners(x, self.n_levels)
        raw = self.raw_density(corners) * self.cfg.density_scale
        inside = (x.abs() <= self.cfg.bound).all(dim=-1)
        return torch.where(inside, density_activation(raw, self.cfg.density_activation), torch.zeros_like(raw)), corners

    def density(self, x):
        return self._sigma(x)[0]

    def query(self, x, d):
        sigma, corners = self._sigma(x)
        return sigma, harmonic_rgb(self.raw_color(corners), d, self.cfg.sh_degree)

    def regularizer(self, seed: int):
        cfg = self.cfg
        if cfg.tv_weight <= 0 and cfg.tv_color_weight <= 0:
            return None
        n = self.n_levels
        r = self.levels.resolutions[n - 1]
        v = tv_vertices(seed, cfg.tv_samples, r ** self.dim)
        step = 2.0 * cfg.bound / (r - 1)
        coords = torch.stack([((v // r ** a) % r).float() for a in range(self.dim)], 1)
        x = coords * step - cfg.bound

        def raw(p):
            cs = self.corners(p, n)
            return self.raw_density(cs), self.raw_color(cs).reshape(p.shape[0], -1)

        d0, c0 = raw(x)
        tv_d, tv_c = 0.0, 0.0
        for a in range(self.dim):
            has = coords[:, a] < r - 1
            d1, c1 = raw(x + step * torch.nn.functional.one_hot(torch.tensor(a), self.dim).float())
            tv_d = tv_d + torch.where(has, (d1 - d0) ** 2, torch.zeros_like(d0))
            tv_c = tv_c + torch.where(has, ((c1 - c0) ** 2).sum(1), torch.zeros_like(d0))
        return cfg.tv_weight * cfg.density_scale ** 2 * tv_d.mean() + cfg.tv_color_weight * tv_c.mean()
