"""A multi-resolution hash grid decoded linearly: the dense grid's density and colour, as a sum of levels.

Level ``l`` is a lattice of ``resolutions[l]^D`` vertices over ``[-bound, bound]^D`` (vertex ``k`` at
``-bound + 2 bound k / (R - 1)``, as in :mod:`.grid`). The first ``dense_levels`` levels are stored densely.
Each finer level keeps ``2^log2_hashmap_size`` entries and finds a vertex's entry with instant-ngp's XOR-of-primes
hash (:data:`.hashenc.PRIMES`). A query interpolates each level's raw density and raw colour coefficients
(bi/trilinear) and sums them over the levels. It then applies the dense grid's activations and view harmonics.
No network decodes the features. So the field is traceable, reads only the density where the integral skips
colour (``keep``), and its parameters are its tables alone. The first ``view_levels`` levels carry the
view-direction harmonics. Finer levels carry only the base colour: view dependence varies slowly in space.

Coarse to fine: training starts with ``initial_levels`` levels, and one more joins at each step of
``add_level_at``. A new level's entries start at 0, so joining does not change the field. The total variation is
taken on the summed field, between neighbouring vertices of the finest level in use (``tv_samples`` consecutive
ones per step). Taken on a hashed level's entries, it would tie unrelated vertices together.

Why collisions cost little here: an outline (2D) or a surface (3D) touches few of a fine level's vertices, and
the dense coarse levels carry free space and the inside. ``hashgrid/psnr`` in ``benchmarks/hashgrid_profile.py``
compares this field with the dense grid and the instant-ngp hash grid at 10 s.
Twin: :mod:`mitnerf.reference.fields.hashlinear`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import drjit as dr
import numpy as np
from drjit.auto.ad import Float, UInt32

from ..errors import CheckpointError, ConfigError
from ..settings import setting
from .base import density_activation
from .grid import GridSettings, LatticeField, tv_vertices
from .lattice import lattice_corners
from .hashenc import vertex_entry


@dataclass
class HashLinearConfig(GridSettings):
    """Levels and tables, with the dense grid's activations and regularisers."""

    resolutions: tuple = setting((65, 129, 257), lo=2, hi=8193)
    """Vertices per axis of each level, coarse to fine (up to 8193 in 2D, 513 in 3D)."""
    dense_levels: int = setting(2, lo=0, hi=32)
    """The first levels are stored densely; finer ones are hashed."""
    log2_hashmap_size: int = setting(13, lo=4, hi=24)
    """Entries of each hashed level, as a power of two (a level with fewer vertices is stored densely)."""
    view_dependent: bool = setting(True, flag="--view-dependence")
    """View-dependent colour: harmonics of the view direction up to ``sh_degree`` (as the dense grid)."""
    view_levels: int = setting(1, lo=1, hi=32)
    """The first levels carry the view harmonics; finer ones only the base colour."""
    initial_levels: int = setting(2, lo=1, hi=32)
    """Levels in use at the start (coarse to fine)."""
    add_level_at: tuple = setting((150,), lo=1, hi=1e9)
    """Training steps at which the next level joins."""
    tv_weight: float = setting(1e-4, lo=0, hi=1e9)
    """Total-variation weight on the summed raw density (0: none)."""
    tv_color_weight: float = setting(1e-2, lo=0, hi=1e9)
    """Total-variation weight on the summed colour coefficients."""
    tv_samples: int = setting(8192, lo=0, hi=1 << 26)
    """Vertices of the finest level in use per step for the total variation (0: all)."""

    def settle(self) -> None:
        """1 to 32 levels of whole, increasing resolutions (at most 513 in 3D)."""
        top = 8193 if self.dim == 2 else 513
        if not 1 <= len(self.resolutions) <= 32 or any(r != int(r) or r > top for r in self.resolutions):
            raise ConfigError(f"resolutions needs 1 to 32 levels of whole numbers up to {top}, e.g. --set "
                              "resolutions=[65,129,257]")
        self.resolutions = tuple(int(r) for r in self.resolutions)
        if self.view_color != "rgb":
            raise ConfigError(f"--set view_color={self.view_color}: grey harmonics are the dense grid's; use "
                              "--set view_color=rgb with this field, or the field grid")
        if list(self.resolutions) != sorted(set(self.resolutions)):
            raise ConfigError(f"resolutions must increase from level to level, got {list(self.resolutions)}")
        super().settle()

    def levels_at(self, step: int) -> int:
        """Levels in use at training step ``step``."""
        n = len(self.resolutions)
        return min(n, min(self.initial_levels, n) + sum(step >= s for s in self.add_level_at))

    def final(self) -> "HashLinearConfig":       # every level in use
        return dataclasses.replace(self, initial_levels=len(self.resolutions))

    @property
    def schedule_end(self) -> int:
        return max(self.add_level_at, default=0)


@dataclass(frozen=True)
class Levels:
    """Where each level lives: entries per level, whether dense, and offsets into the two flat tables."""

    resolutions: tuple
    sizes: tuple         # entries
    dense: tuple
    coeffs: tuple        # colour coefficients per channel (K for the view levels, else 1)
    offsets: tuple       # first entry of each level in the density table
    color_offsets: tuple  # first float of each level in the colour table (one more: the end)

    def widths(self, n: int) -> tuple[int, int]:
        """Floats of the density and colour tables when the first ``n`` levels are in use."""
        return self.offsets[n - 1] + self.sizes[n - 1], self.color_offsets[n]

    def in_use(self, density_width: int) -> int:
        """Levels in use, read from the density table's length."""
        return max(n for n in range(1, len(self.sizes) + 1) if self.widths(n)[0] <= density_width)


def levels_of(cfg: HashLinearConfig) -> Levels:
    """The table layout of ``cfg`` (both engines build theirs from it)."""
    table = 2 ** cfg.log2_hashmap_size
    dense = [level < cfg.dense_levels or r ** cfg.dim <= table for level, r in enumerate(cfg.resolutions)]
    sizes = [r ** cfg.dim if d else table for r, d in zip(cfg.resolutions, dense)]
    coeffs = [cfg.color_coeffs if level < cfg.view_levels else 1 for level in range(len(sizes))]
    offsets = [sum(sizes[:level]) for level in range(len(sizes))]
    color = [sum(3 * c * s for c, s in zip(coeffs[:level], sizes[:level])) for level in range(len(sizes) + 1)]
    return Levels(cfg.resolutions, tuple(sizes), tuple(dense), tuple(coeffs), tuple(offsets), tuple(color))


class HashLinearField(LatticeField):
    def __init__(self, cfg: HashLinearConfig):
        super().__init__(cfg)
        self.levels = levels_of(cfg)
        self.K = cfg.color_coeffs

    def levels_in(self, params) -> int:
        return self.levels.in_use(dr.width(params["density"]))

    def init_numpy(self, seed: int = 0) -> dict[str, np.ndarray]:
        nd, nc = self.levels.widths(self.cfg.levels_at(0))
        density = np.zeros(nd, np.float32)
        density[:self.levels.sizes[0]] = self.cfg.density_init / self.cfg.density_scale
        color = np.zeros(nc, np.float32)
        color[:self.levels.color_offsets[1]] = np.random.default_rng(seed).normal(0, 0.01, self.levels.color_offsets[1])
        return {"density": density, "color": color}

    def from_numpy(self, arrays) -> dict:
        d, c = (np.asarray(arrays[k], np.float32).ravel() for k in ("density", "color"))
        if (d.size, c.size) not in [self.levels.widths(n) for n in range(1, len(self.levels.sizes) + 1)]:
            raise CheckpointError(f"tables of {d.size} and {c.size} floats fit no level count of this configuration; "
                                  "the checkpoint was saved with another configuration")
        return {"density": Float(d), "color": Float(c)}

    def to_numpy(self, params) -> dict:
        return {k: np.asarray(params[k]) for k in ("density", "color")}

    def schedule(self, step: int, params) -> dict | None:
        """Tables grown by the levels that join at ``step`` (zeros), or None."""
        n = self.cfg.levels_at(step)
        if n == self.levels_in(params):
            return None
        old = self.to_numpy(params)
        new = {k: np.zeros(w, np.float32) for k, w in zip(("density", "color"), self.levels.widths(n))}
        for k in new:
            new[k][:old[k].size] = old[k]
        return self.from_numpy(new)

    def corners(self, x: list, n: int) -> list:
        """Per level in use: ``[(entry UInt32, weight Float)]`` of the cell corners around ``x``."""
        return [[(vertex_entry(key, level, self.levels), w)
                 for key, w in lattice_corners(x, self.cfg.bound, self.levels.resolutions[level])]
                for level in range(n)]

    def raw_density(self, params, corners) -> Float:
        raw = Float(0.0)
        for level, cs in enumerate(corners):
            for entry, w in cs:
                raw = dr.fma(dr.gather(Float, params["density"], self.levels.offsets[level] + entry), w, raw)
        return raw

    def raw_color(self, params, corners, active=True) -> list:
        """Summed colour coefficients, ``3 K`` arrays (channel-major); nothing is read where ``active`` is False."""
        K, lv = self.K, self.levels
        raw = [Float(0.0)] * (3 * K)
        for level, cs in enumerate(corners):
            k_l = lv.coeffs[level]
            for entry, w in cs:
                base = lv.color_offsets[level] + entry * (3 * k_l)
                for c in range(3):
                    for k in range(k_l):
                        v = dr.gather(Float, params["color"], base + c * k_l + k, active)
                        raw[c * K + k] = dr.fma(v, w, raw[c * K + k])
        return raw

    def _sigma(self, params, x):
        x = list(x)
        corners = self.corners(x, self.levels_in(params))
        raw = self.raw_density(params, corners) * self.cfg.density_scale
        inside = dr.all([dr.abs(xi) <= self.cfg.bound for xi in x])
        return dr.select(inside, density_activation(raw, self.cfg.density_activation), 0.0), corners

    def regularizer(self, params, seed: UInt32) -> Float | None:
        """Total variation of the summed raw density and colour coefficients: the mean over vertices of the finest
        level in use of the squared differences to the next vertex along each axis; None when both weights are 0."""
        cfg = self.cfg
        if cfg.tv_weight <= 0 and cfg.tv_color_weight <= 0:
            return None
        n = self.levels_in(params)
        r = self.levels.resolutions[n - 1]
        v = tv_vertices(seed, cfg.tv_samples, r ** self.dim)
        step = 2.0 * cfg.bound / (r - 1)
        coords = [Float((v // r ** a) % r) for a in range(self.dim)]
        x = [k * step - cfg.bound for k in coords]

        def raw(p):
            cs = self.corners(p, n)
            return self.raw_density(params, cs), self.raw_color(params, cs)

        d0, c0 = raw(x)
        tv_d, tv_c = Float(0.0), Float(0.0)
        for a in range(self.dim):
            has = coords[a] < r - 1
            d1, c1 = raw([xi + step if b == a else xi for b, xi in enumerate(x)])
            tv_d += dr.select(has, dr.square(d1 - d0), 0.0)
            tv_c += dr.select(has, sum(dr.square(p - q) for p, q in zip(c1, c0)), 0.0)
        return cfg.tv_weight * cfg.density_scale ** 2 * dr.mean(tv_d) + cfg.tv_color_weight * dr.mean(tv_c)
