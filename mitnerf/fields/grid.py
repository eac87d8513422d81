"""Dense grid field: a density image (2D) or voxel grid (3D) plus colour, interpolated.

Values live on a lattice of vertices over a box: by default ``R^D`` vertices spanning ``[-bound, bound]^D``
(vertex ``k`` at ``-bound + 2 bound k / (R - 1)``); with ``box`` and ``cells``, ``n_a`` vertices from ``lo_a`` to
``hi_a`` along each axis, ``R`` on the fullest. Sized from the data, the lattice spans the box around the object
(the views' visual hull: the same vertices in less volume, so finer cells for the same memory). A query
interpolates raw values (bi/trilinear) and *then* applies the activations, so a surface can be sharper than a
cell, as in Plenoxels and DVGO. Outside the box the density is 0. Every operation is a gather, so
the field is traceable (it runs inside the fused march); where the integral does not use a sample's colour
(``keep``), only the density is read (one read per corner instead of 1 + the colour's reads), so
empty space and the inside of a surface cost that much less in the primal and the adjoint
(``benchmarks/grid_step.py``). With ``density_refine`` k the density has a lattice of its own, k times finer than
the colour's over the same box, so edges and thin parts get finer cells for one float a vertex (grid-3d does so
where the views ask for it: ``Sizing.density_refine``, ``benchmarks/lego.py``). Twin:
:mod:`mitnerf.reference.fields.grid`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import drjit as dr
import numpy as np
from drjit.auto.ad import Float, UInt32

from ..errors import CheckpointError, ConfigError
from ..rng import hash_u32
from ..settings import setting
from .base import Field, FieldConfig, density_activation
from .harmonics import harmonic_rgb
from .lattice import corner_weights, interpolate, read_record, record_layout, resample, strides


MAX_SH_DEGREE = {2: 8, 3: 2}
"""Highest degree of the view harmonics: a circle's harmonics cost two coefficients a degree, a sphere's
``2 degree + 1``."""


@dataclass
class GridSettings(FieldConfig):
    """What the dense grid's config and the configs built like it (:mod:`.hashlinear`) share: settings, the count of
    view harmonics, and the checks of the density scale, the total-variation weights and the harmonics' degree."""

    sh_degree: int = setting(1, lo=1, hi=8, flag="--sh-degree")
    """Degree of the view-direction harmonics when the colour is view-dependent: up to 8 in 2D, 2 in 3D."""
    view_color: str = setting("rgb", choices=("rgb", "grey"))
    """What varies with the view: ``rgb``, each channel with harmonics of its own (``3 K`` floats a vertex); ``grey``,
    one set of harmonics above degree 0 added to all three channels (``3 + K - 1``): a white light's highlights on
    a dielectric are grey, and at degree 1 a vertex holds half the floats, so a step reads and writes half the
    colour on the lattice ``rgb`` would have (the dense grid; ``benchmarks/lego.py`` part ``grey``)."""
    density_init: float = setting(-1.0, lo=-1e3, hi=1e3)
    """Initial raw density everywhere (softplus(-1) = 0.31: slightly transparent)."""
    density_scale: float = setting(10.0, lo=0, hi=1e9)
    """Raw values are multiplied by this before the activation: a larger effective learning
    rate for density, which has to go from transparent to opaque."""

    def settle(self) -> None:
        """A harmonics degree within what the dimension carries."""
        top = MAX_SH_DEGREE[self.dim]
        if self.sh_degree > top:
            raise ConfigError(f"--sh-degree {self.sh_degree}: a {self.dim}D field carries harmonics up to degree "
                              f"{top}; choose 1 to {top}")

    @property
    def color_coeffs(self) -> int:
        """Harmonics of the view direction: ``K``, 1 without view dependence."""
        if not self.view_dependent:
            return 1
        return 1 + 2 * self.sh_degree if self.dim == 2 else (self.sh_degree + 1) ** 2

    @property
    def grey(self) -> bool:
        """Whether the harmonics above degree 0 are shared by the three channels (:attr:`view_color`)."""
        return self.view_color == "grey" and self.color_coeffs > 1

    @property
    def color_floats(self) -> int:
        """Colour floats a vertex: ``3 K``, or ``3 + K - 1`` with grey harmonics."""
        return 3 + self.color_coeffs - 1 if self.grey else 3 * self.color_coeffs


@dataclass
class GridConfig(GridSettings):
    """A dense grid of density and colour."""

    resolution: int = setting(256, lo=2, hi=8193, flag="--grid-resolution")
    """Vertices along the (colour) lattice's fullest axis at the end of training (the other axes follow ``cells`` or
    the box; up to 8193 in 2D, 513 in 3D); a refined density has ``density_refine (R - 1) + 1``."""
    initial_resolution: int | None = setting(None, lo=2, hi=8193)
    """Vertices per axis at the start (coarse to fine); None: ``resolution``."""
    upsample_at: tuple = setting((), lo=1, hi=1e9)
    """Training steps at which the resolution doubles (capped at ``resolution``)."""
    view_dependent: bool = setting(False, flag="--view-dependence")
    """View-dependent colour: harmonics of the view direction up to ``sh_degree`` per vertex."""
    tv_weight: float = setting(1e-3, lo=0, hi=1e9)
    """Total-variation weight on the density grid (0: none)."""
    tv_color_weight: float = setting(0.0, lo=0, hi=1e9)
    """Total-variation weight on the colour grid."""
    tv_samples: int = setting(65536, lo=0, hi=1 << 26)
    """Vertices per step and array (density, colour) for the total variation, consecutive from a random start (0: the
    whole grid)."""
    box: tuple | None = setting(None, lo=-1e6, hi=1e6)
    """The lattice's extent ``(lo_x, lo_y[, lo_z], hi_x, hi_y[, hi_z])`` in the field's coordinates; the density is 0
    outside it. None: the cube ``[-bound, bound]^D``. A sized recipe sets it from the data (the box around the
    training views' visual hull), so the same vertices cover only what can hold the object."""
    cells: tuple | None = setting(None, lo=0, above=True, hi=1e6)
    """Cells along each axis, relative to one another (``resolution`` counts the vertices of the axis with the most).
    None: in the box's proportions (cubic cells)."""
    density_refine: int = setting(1, lo=1, hi=4)
    """Density cells per colour cell along each axis: the density lattice has ``k (n - 1) + 1`` vertices where the
    colour's has ``n``, so edges and thin parts get ``k`` times finer cells for one float a vertex (the colour has
    ``3 K``). A sized recipe keeps the unrefined grid's floats, on fewer colour vertices (:attr:`refined_share`).
    ``tv_weight`` stays as written: on k times finer spacings neighbours differ about k^2 less, so the density's
    total variation smooths less."""
    color_packets: bool = setting(True)
    """Each vertex's colour floats read in packets of 4 or 16 floats, padded to whole packets in memory where that
    adds at most a quarter (:attr:`color_layout`; 3D RGB view harmonics of degree 1: 12 floats, three packets of 4;
    of degree 2: 27 floats in 32; 2D of degree 2: 15 in 16): a corner's colour takes one read (and one scatter in
    the adjoint) a packet rather than one a float, and the colour, its gradient and Adam's two moments take the
    padded floats (``benchmarks/records.py``); False: the floats alone, read one by one. Weights on disk and the
    torch twin hold the floats alone either way."""

    @property
    def color_layout(self) -> tuple[int, int]:
        """``(floats a vertex's colour record takes in memory, floats a read takes)``: where :attr:`color_packets`,
        :func:`~.lattice.record_layout` of :attr:`color_floats`, else the floats alone, read one by one. Pad floats
        are 0 and stay 0: no loss reads them (a resize resamples them, zeros to zeros), so their gradient is 0."""
        return record_layout(self.color_floats) if self.color_packets else (self.color_floats, 1)

    @property
    def color_stride(self) -> int:
        """Floats a vertex's colour record takes in memory (:attr:`color_layout`)."""
        return self.color_layout[0]

    def settle(self) -> None:
        """The initial resolution defaults to the final one; 3D grids have at most 513 vertices a side (a refined
        density 1025); a box has ``2 D`` bounds, each low one below its high one, and ``cells`` one positive share per
        axis."""
        if self.initial_resolution is None:
            self.initial_resolution = self.resolution
        top = most_vertices(self.dim)
        for name in ("resolution", "initial_resolution"):
            if getattr(self, name) > top:
                raise ConfigError(f"{'--grid-resolution' if name == 'resolution' else '--set ' + name} "
                                  f"{getattr(self, name)}: a {self.dim}D grid has at most {top} vertices a side")
        fine = self.density_refine * (max(self.resolution, self.initial_resolution) - 1) + 1
        if fine > 2 * top - 1:
            raise ConfigError(f"--set density_refine={self.density_refine}: the density lattice would have {fine} "
                              f"vertices a side, and a {self.dim}D one has at most {2 * top - 1}; choose a smaller "
                              "density_refine or --grid-resolution")
        D = self.dim
        if self.box is not None:
            self.box = tuple(float(v) for v in self.box)
            if len(self.box) != 2 * D or any(self.box[a] >= self.box[D + a] for a in range(D)):
                raise ConfigError(f"box needs {2 * D} numbers, the low ends then the high ends, each low one below "
                                  f"its high one, e.g. --set box=[{','.join(['-1'] * D + ['1'] * D)}]")
        if self.cells is not None:
            self.cells = tuple(float(v) for v in self.cells)
            if len(self.cells) != D:
                raise ConfigError(f"cells needs one share per axis ({D}), e.g. --set cells=[{','.join(['1'] * D)}]")
        super().settle()

    @property
    def extent(self) -> tuple[list, list]:
        """The lattice's low and high ends per axis."""
        if self.box is None:
            return [-self.bound] * self.dim, [self.bound] * self.dim
        return list(self.box[:self.dim]), list(self.box[self.dim:])

    def lattice(self, res: int) -> list:
        """Vertices per axis of the lattice whose fullest axis has ``res`` (at least 2 on each)."""
        lo, hi = self.extent
        share = self.cells or [h - l for l, h in zip(lo, hi)]
        return [max(2, round((res - 1) * s / max(share)) + 1) for s in share]

    @property
    def refined_share(self) -> float:
        """The share of an unrefined lattice's vertices this grid may keep for the same floats: ``(1 + 3 K) / (k^D +
        3 K)`` (``K`` colour coefficients, ``k`` = :attr:`density_refine`); 1 unrefined. Grey harmonics keep the
        share of ``rgb`` ones: the same lattice, in fewer floats."""
        C, k = 3 * self.color_coeffs, self.density_refine
        return (1 + C) / (k ** self.dim + C)

    def density_lattice(self, res: int) -> list:
        """Vertices per axis of the density lattice that goes with the colour lattice ``lattice(res)``."""
        return [self.density_refine * (n - 1) + 1 for n in self.lattice(res)]

    def resolution_of_sizes(self, n_density: int, n_color: int, stride: int | None = None) -> int:
        """The colour lattice's fullest axis of a grid with ``n_density`` density floats and ``n_color`` colour ones,
        ``stride`` a vertex (:attr:`color_floats` where None; :meth:`resolution_with`); sizes that fit no lattice of
        this config are refused."""
        C = stride or self.color_floats
        res = self.resolution_with(n_color // C) if n_color % C == 0 else None
        if res is None or int(np.prod(self.density_lattice(res))) != n_density:
            shown = n_color // C * self.color_floats if n_color % C == 0 else n_color      # as the weights hold them
            raise CheckpointError(f"a grid of {n_density} density and {shown} colour values fits no lattice of this "
                                  "box, cells, view dependence, view_color and density_refine; the weights were saved "
                                  "with another configuration")
        return res

    def resolution_with(self, n: int) -> int:
        """Vertices along the fullest axis of the lattice with ``n`` vertices in all (at least the D-th root of
        ``n``: the search starts there, and the count grows with each step)."""
        res = max(2, int(n ** (1.0 / self.dim)) - 1)
        while (size := int(np.prod(self.lattice(res)))) < n:
            res += 1
        if size != n:
            raise CheckpointError(f"a grid of {n} vertices fits no resolution of this box and cells; the weights "
                                  "were saved with another configuration")
        return res

    def final(self) -> "GridConfig":
        return dataclasses.replace(self, initial_resolution=self.resolution)

    @property
    def schedule_end(self) -> int:
        return max(self.upsample_at, default=0)

    def resolution_at(self, step: int) -> int:
        res = self.initial_resolution
        for _ in range(sum(step >= s for s in self.upsample_at)):     # one doubling per step passed
            res = min(2 * (res - 1) + 1, self.resolution)
        return res


class LatticeField(Field):
    """Raw values interpolated on lattices, then activated (the dense grid, :mod:`.hashlinear`): every read is a
    gather, and the colour only where the integral keeps it. A subclass gives ``_sigma(params, x) -> (sigma,
    corners)`` and ``raw_color(params, corners, active) -> 3 K arrays`` (nothing read where ``active`` is False)."""

    traceable = skips_color = True

    def density(self, params, x) -> Float:
        return self._sigma(params, x)[0]

    def query(self, params, x, d, keep=None):
        sigma, corners = self._sigma(params, x)
        raw = self.raw_color(params, corners, True if keep is None else keep(sigma))
        return sigma, harmonic_rgb(raw, d, self.cfg.color_coeffs, self.cfg.sh_degree, self.cfg.grey)


class GridField(LatticeField):

    scattered = True

    def init_numpy(self, seed: int = 0) -> dict[str, np.ndarray]:
        cfg, res = self.cfg, self.cfg.initial_resolution
        shape = tuple(cfg.lattice(res)[::-1])         # numpy order: x last
        color = np.random.default_rng(seed).normal(0, 0.01, shape + (cfg.color_floats,)).astype(np.float32)
        return {"density": np.full(cfg.density_lattice(res)[::-1], cfg.density_init / cfg.density_scale, np.float32),
                "color": color}

    def resolution_of(self, params) -> int:
        """Vertices along the fullest axis of the colour lattice ``params`` hold (read from its size; the density's
        size checked against it)."""
        return self.cfg.resolution_of_sizes(dr.width(params["density"]), dr.width(params["color"]),
                                            self.cfg.color_stride)

    def shape_of(self, params) -> list:
        """Vertices per axis of the colour lattice ``params`` hold, x first."""
        return self.cfg.lattice(self.resolution_of(params))

    def density_shape_of(self, params) -> list:
        """Vertices per axis of the density lattice ``params`` hold, x first (the colour's, unless refined)."""
        return self.cfg.density_lattice(self.resolution_of(params))

    def to_numpy(self, params) -> dict:
        shape = tuple(self.shape_of(params)[::-1]) + (self.cfg.color_floats,)
        return {"density": np.asarray(params["density"]).reshape(self.density_shape_of(params)[::-1]),
                "color": self.saved("color", params["color"]).reshape(shape)}

    def from_numpy(self, arrays) -> dict:
        return {k: Float(self.stored(k, arrays[k])) for k in ("density", "color")}

    def saved(self, name: str, values) -> np.ndarray:
        """The colour's without its pad floats: ``[vertices, color_floats]`` (a view, not a copy)."""
        a = np.asarray(values)
        return a.reshape(-1, self.cfg.color_stride)[:, :self.cfg.color_floats] if name == "color" else a

    def stored(self, name: str, values: np.ndarray) -> np.ndarray:
        """Flat, the colour's records padded (:attr:`GridConfig.color_stride`); colour values that fill no whole
        records are refused (:class:`~mitnerf.errors.CheckpointError`)."""
        a = np.asarray(values, np.float32).ravel()
        C, S = self.cfg.color_floats, self.cfg.color_stride
        if name == "color" and S != C:
            if a.size % C:                  # it might fill whole padded records: refused here, not misread
                raise CheckpointError(f"{a.size} colour values fill no whole vertices of {C} floats (view "
                                      "dependence, view_color); the weights were saved with another configuration")
            a = np.pad(a.reshape(-1, C), ((0, 0), (0, S - C))).ravel()
        return a

    def _sigma(self, params, x):
        """Density at ``x``, and the colour lattice's cell corners around it (the density's when ``density_refine`` is
        1)."""
        cfg, res = self.cfg, self.resolution_of(params)
        corners, inside = corner_weights(list(x), *cfg.extent, cfg.density_lattice(res))
        raw = interpolate(params["density"], 1, corners)[0] * cfg.density_scale
        if cfg.density_refine > 1:
            corners = corner_weights(list(x), *cfg.extent, cfg.lattice(res))[0]
        return dr.select(inside, density_activation(raw, self.cfg.density_activation), 0.0), corners

    def raw_color(self, params, corners, active=True) -> list:
        return interpolate(params["color"], self.cfg.color_floats, corners, active, self.cfg.color_layout)

    def resize(self, params, res: int) -> dict:
        """Resample the colour to ``lattice(res)`` and the density to ``density_lattice(res)`` (coarse to fine)."""
        if res == self.resolution_of(params):
            return params
        cfg, layout = self.cfg, self.cfg.color_layout
        with dr.suspend_grad():
            dens = resample(dr.detach(params["density"]), 1, cfg.extent, self.density_shape_of(params),
                            cfg.density_lattice(res))
            col = resample(dr.detach(params["color"]), layout[0], cfg.extent, self.shape_of(params), cfg.lattice(res),
                           layout)
            dr.eval(dens, col)
        return {"density": dens, "color": col}

    def schedule(self, step: int, params) -> dict | None:
        res = self.cfg.resolution_at(step)
        return self.resize(params, res) if res != self.resolution_of(params) else None

    def regularizer(self, params, seed: UInt32) -> Float | None:
        """Total variation: per axis and channel, the mean squared difference of neighbouring vertices (at
        :func:`tv_vertices`: distinct and consecutive, so the reads stay in cache), weighted and summed in one
        reduction per array; None when both weights are 0."""
        cfg = self.cfg
        if cfg.tv_weight <= 0 and cfg.tv_color_weight <= 0:
            return None
        total = Float(0.0)
        for name, weight, C, layout, shape in (
                ("density", cfg.tv_weight, 1, None, self.density_shape_of(params)),
                ("color", cfg.tv_color_weight, cfg.color_floats, cfg.color_layout, self.shape_of(params))):
            if weight <= 0:
                continue
            step = strides(shape)
            v = tv_vertices(seed, cfg.tv_samples, int(np.prod(shape)))
            ok = [(v // s) % n < n - 1 for s, n in zip(step, shape)]      # has a neighbour along each axis
            here = read_record(params[name], C, v, True, layout)
            per_vertex = Float(0.0)
            for axis_step, has in zip(step, ok):
                there = read_record(params[name], C, v + axis_step, has, layout)
                for c in range(C):
                    per_vertex += dr.select(has, dr.square(there[c] - here[c]), 0.0)
            total = total + weight * (cfg.density_scale ** 2 if name == "density" else 1.0) * dr.mean(per_vertex)
        return total


def most_vertices(dim: int, refine: int = 1) -> int:
    """The most vertices a side a grid's colour lattice may have: 8193 in 2D, 513 in 3D, and fewer where its density,
    ``refine`` times finer, would pass twice that less one (:meth:`GridConfig.settle` refuses more)."""
    top = 8193 if dim == 2 else 513
    return min(top, (2 * top - 2) // refine + 1)


TV_SALT = 0x2545F491
"""Seed salt of the total variation's vertices (both engines)."""


def tv_vertices(seed, samples: int, n: int):
    """The vertices whose total variation a step takes: all ``n``, or (``0 < samples < n``) ``samples``
    consecutive ones in storage order from a random start, wrapping around (distinct, and read in order).
    ``seed`` UInt32 (Dr.Jit) -> UInt32 ``[samples]``; twin: the torch field's ``tv_vertices``."""
    if not 0 < samples < n:
        return dr.arange(UInt32, n)
    start = hash_u32(hash_u32(seed ^ TV_SALT)) % n            # batch_indices(seed ^ TV_SALT, 1, n)
    return (start + dr.arange(UInt32, samples)) % n
