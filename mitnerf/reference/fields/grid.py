"""Twin of :mod:`mitnerf.fields.grid`: the same vertices, corner order, weights and activations (autograd)."""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from ...fields.base import cell_corners
from ...fields.grid import TV_SALT, GridConfig
from ...fields.lattice import lattice_points, strides
from ...rng import batch_indices
from .harmonics import harmonic_rgb
from .mlp import TwinField, density_activation


def lattice_corners(x: torch.Tensor, bound: float, res: int) -> list:
    """``x [n, D]`` -> list of (D integer coordinates [n], weight [n]), in the Dr.Jit corner order."""
    D = x.shape[1]
    return box_corners(x, [-bound] * D, [bound] * D, [res] * D)


def box_corners(x: torch.Tensor, lo: list, hi: list, shape: list) -> list:
    """:func:`lattice_corners` on a box: ``shape[a]`` vertices from ``lo[a]`` to ``hi[a]`` along axis ``a``."""
    u = []
    for xi, l, h, n in zip(x.unbind(1), lo, hi, shape):
        c, r = 0.5 * (l + h), 0.5 * (h - l)
        u.append(torch.clamp(((xi if c == 0 else xi - c) * (1.0 / r) + 1.0) * (0.5 * (n - 1)), 0.0, n - 1.0001))
    u = torch.stack(u, 1)
    i0 = torch.floor(u)
    return list(cell_corners(list(i0.long().unbind(1)), list((u - i0).unbind(1))))


def corner_weights(x: torch.Tensor, lo: list, hi: list, shape: list):
    """``x [n, D]`` -> list of (flat index [n], weight [n]) and inside [n]."""
    step = strides(shape)
    corners = [(sum(k * s for s, k in zip(step, key)), w) for key, w in box_corners(x, lo, hi, shape)]
    low, high = x.new_tensor(lo), x.new_tensor(hi)
    return corners, ((x >= low) & (x <= high)).all(dim=-1)


def interpolate(grid: torch.Tensor, corners) -> torch.Tensor:
    """``grid [V, C]`` -> ``[n, C]``."""
    return sum(grid[index] * weight[:, None] for index, weight in corners)


class GridField(TwinField):
    def __init__(self, cfg: GridConfig):
        super().__init__(cfg)
        res = cfg.initial_resolution
        self.density_grid = nn.Parameter(torch.zeros(int(np.prod(cfg.density_lattice(res))), 1))
        self.color_grid = nn.Parameter(torch.zeros(int(np.prod(cfg.lattice(res))), cfg.color_floats))

    @property
    def res(self) -> int:
        """Vertices along the colour lattice's fullest axis (read from its size, as the Dr.Jit field does)."""
        return self.cfg.resolution_of_sizes(self.density_grid.numel(), self.color_grid.numel())

    @property
    def shape(self) -> list:
        """The colour lattice's vertices per axis."""
        return self.cfg.lattice(self.res)

    @property
    def density_shape(self) -> list:
        """The density lattice's vertices per axis (the colour's, unless refined)."""
        return self.cfg.density_lattice(self.res)

    def load_numpy(self, arrays) -> None:
        d = torch.as_tensor(np.asarray(arrays["density"], np.float32).reshape(-1, 1))
        c = torch.as_tensor(np.asarray(arrays["color"], np.float32).reshape(-1, self.cfg.color_floats))
        self.density_grid, self.color_grid = nn.Parameter(d), nn.Parameter(c)

    def to_numpy(self) -> dict:
        return {"density": self.density_grid.detach().numpy().reshape(self.density_shape[::-1]),
                "color": self.color_grid.detach().numpy().reshape(tuple(self.shape[::-1]) + (-1,))}

    def schedule(self, step: int) -> bool:
        res = self.cfg.resolution_at(step)
        if res == self.res:
            return False
        cfg = self.cfg
        with torch.no_grad():
            dens = resample(self.density_grid, cfg.extent, self.density_shape, cfg.density_lattice(res))
            col = resample(self.color_grid, cfg.extent, self.shape, cfg.lattice(res))
        self.density_grid, self.color_grid = nn.Parameter(dens), nn.Parameter(col)
        return True

    def density(self, x):
        corners, inside = corner_weights(x, *self.cfg.extent, self.density_shape)
        raw = interpolate(self.density_grid, corners)[:, 0] * self.cfg.density_scale
        return torch.where(inside, density_activation(raw, self.cfg.density_activation), torch.zeros_like(raw))

    def query(self, x, d):
        corners, _ = corner_weights(x, *self.cfg.extent, self.shape)
        cfg, raw = self.cfg, interpolate(self.color_grid, corners)
        raw = raw if cfg.grey else raw.reshape(-1, 3, cfg.color_coeffs)
        return self.density(x), harmonic_rgb(raw, d, cfg.sh_degree, cfg.grey)

    def regularizer(self, seed: int):
        cfg = self.cfg
        if cfg.tv_weight <= 0 and cfg.tv_color_weight <= 0:
            return None
        total = 0.0
        for grid, weight, scale, shape in (
                (self.density_grid, cfg.tv_weight, cfg.density_scale ** 2, self.density_shape),
                (self.color_grid, cfg.tv_color_weight, 1.0, self.shape)):
            if weight <= 0:
                continue
            step = strides(shape)
            v = tv_vertices(seed, cfg.tv_samples, int(np.prod(shape)))
            per_vertex = 0.0
            for s, n in zip(step, shape):
                ok = ((v // s) % n) < n - 1
                diff = grid[torch.where(ok, v + s, v)] - grid[v]
                per_vertex = per_vertex + torch.where(ok[:, None], diff * diff, torch.zeros_like(diff)).sum(1)
            total = total + weight * scale * per_vertex.mean()
        return total


def resample(grid: torch.Tensor, extent: tuple, shape: list, new_shape: list) -> torch.Tensor:
    """Twin of :func:`mitnerf.fields.lattice.resample`: ``grid [V, C]`` on ``shape`` -> ``[V', C]`` on ``new_shape``."""
    return interpolate(grid, corner_weights(torch.from_numpy(lattice_points(extent, new_shape)), *extent, shape)[0])


def tv_vertices(seed: int, samples: int, n: int) -> torch.Tensor:
    """Twin of :func:`mitnerf.fields.grid.tv_vertices`: all ``n`` vertices, or ``samples`` consecutive ones
    from a random start (wrapping)."""
    if not 0 < samples < n:
        return torch.arange(n)
    start = int(batch_indices(seed ^ TV_SALT, 1, n)[0])
    return (start + torch.arange(samples)) % n
