"""Dense grid field: a density image (2D) or voxel grid (3D) plus colour, interpolated.

Values live on ``R^D`` vertices spanning ``[-bound, bound]^D`` (vertex ``k`` at
``-bound + 2 bound k / (R - 1)``). A query interpolates raw values (bi/trilinear) and
*then* applies the activations (density: softplus / relu / trunc_exp; colour:
sigmoid), so a surface can be sharper than a cell, as in Plenoxels and DVGO.
Outside the bound the density is 0.

* **View dependence** (optional, as Plenoxels): each colour channel is an expansion in
  the view direction up to ``sh_degree`` (:func:`view_basis`): in 2D the circular
  harmonics ``1, cos t, sin t, cos 2t, sin 2t``, in 3D the real spherical harmonics
  ``1, x, y, z, xy, yz, 3z^2 - 1, xz, x^2 - y^2`` (unnormalised), interpolated per vertex.
* **Coarse to fine**: training starts at ``initial_resolution`` and doubles at the
  steps in ``upsample_at`` up to ``resolution``; :meth:`resize` resamples the grids.
* **Total variation**: :meth:`regularizer` returns ``tv_weight`` times the mean squared
  difference of neighbouring density vertices (plus ``tv_color_weight`` for colour),
  on a random subset of ``tv_samples`` vertices per step (0: all of them).

Every operation is a gather, so the field is traceable (it runs inside the fused
march). Twin: :mod:`mitnerf.reference.fields.grid`.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import numpy as np
from drjit.auto.ad import Float, UInt32

from ..errors import check_number
from ..rng import hash_u32
from .base import check_config, density_activation, sigmoid


@dataclass
class GridConfig:
    """A dense grid of density and colour."""

    dim: int = 2
    """2 (an image of the plane) or 3 (a voxel grid)."""
    resolution: int = 256
    """Vertices per axis at the end of training."""
    initial_resolution: int | None = None
    """Vertices per axis at the start (coarse to fine); None: ``resolution``."""
    upsample_at: tuple = ()
    """Training steps at which the resolution doubles (capped at ``resolution``)."""
    view_dependent: bool = False
    """View-dependent colour: harmonics of the view direction up to ``sh_degree`` per vertex."""
    sh_degree: int = 1
    """Degree of the view-direction expansion (1 or 2) when ``view_dependent``."""
    density_activation: str = "softplus"
    """``softplus``, ``relu`` or ``trunc_exp``, applied after interpolation."""
    density_init: float = -1.0
    """Initial raw density everywhere (softplus(-1) = 0.31: slightly transparent)."""
    density_scale: float = 10.0
    """Raw values are multiplied by this before the activation: a larger effective learning
    rate for density, which has to go from transparent to opaque."""
    tv_weight: float = 1e-3
    """Total-variation weight on the density grid (0: none)."""
    tv_color_weight: float = 0.0
    """Total-variation weight on the colour grid."""
    tv_samples: int = 65536
    """Random vertices per step for the total variation (0: the whole grid)."""
    bound: float = 1.5
    """Half-extent of the grid in world units."""

    def __post_init__(self):
        if self.initial_resolution is None:
            self.initial_resolution = self.resolution
        self.upsample_at = tuple(self.upsample_at)
        top = 8193 if self.dim == 2 else 513
        check_config(self, resolution=(2, top), initial_resolution=(2, top), tv_samples=(0, 1 << 26), sh_degree=(1, 2))
        for name in ("density_scale", "tv_weight", "tv_color_weight"):
            check_number(name, getattr(self, name), 0, 1e9)

    @property
    def color_coeffs(self) -> int:
        if not self.view_dependent:
            return 1
        return 1 + 2 * self.sh_degree if self.dim == 2 else (self.sh_degree + 1) ** 2

    def resolution_at(self, step: int) -> int:
        res = self.initial_resolution
        for s in sorted(self.upsample_at):
            if step >= s:
                res = min(2 * (res - 1) + 1, self.resolution)
        return res


def corner_weights(x: list, bound: float, res: int):
    """Cell corner indices and bi/trilinear weights of points ``x`` (D arrays) in a grid of
    ``res^D`` vertices; also whether each point lies inside ``[-bound, bound]^D``.
    Returns ``(list of (flat index UInt32, weight Float)), inside Bool``."""
    D = len(x)
    inside = None
    i0, frac = [], []
    for xi in x:
        u = dr.clip((xi * (1.0 / bound) + 1.0) * (0.5 * (res - 1)), 0.0, res - 1.0001)
        f = dr.floor(u)
        i0.append(UInt32(f))
        frac.append(u - f)
        ok = dr.abs(xi) <= bound
        inside = ok if inside is None else inside & ok
    corners = []
    for c in range(1 << D):
        index, weight, stride = UInt32(0), Float(1.0), 1
        for a in range(D):
            bit = (c >> a) & 1
            index = index + (i0[a] + bit) * stride
            weight = weight * (frac[a] if bit else 1.0 - frac[a])
            stride *= res
        corners.append((index, weight))
    return corners, inside


def interpolate(grid: Float, channels: int, corners) -> list:
    """Interpolated values of a grid stored vertex-major (``channels`` floats per vertex)."""
    out = [Float(0.0)] * channels
    for index, weight in corners:
        for c in range(channels):
            out[c] = dr.fma(dr.gather(Float, grid, index * channels + c), weight, out[c])
    return out


def view_basis(d: list, degree: int) -> list:
    """Harmonics of a unit view direction up to ``degree`` (1 or 2); works on Dr.Jit arrays
    and torch tensors alike. 2D ``d = (cos t, sin t)``: ``1, cos t, sin t, cos 2t, sin 2t``;
    3D: ``1, x, y, z, xy, yz, 3z^2 - 1, xz, x^2 - y^2``."""
    one = d[0] * 0 + 1
    out = [one, *d]
    if degree >= 2:
        if len(d) == 2:
            c, s = d
            out += [c * c - s * s, 2 * c * s]
        else:
            x, y, z = d
            out += [x * y, y * z, 3 * z * z - 1, x * z, x * x - y * y]
    return out


class GridField:
    """See the module docstring."""

    def __init__(self, cfg: GridConfig):
        self.cfg = cfg
        self.dim = cfg.dim
        self.traceable = True

    # ------------------------------------------------------------------ storage
    def init_numpy(self, seed: int = 0) -> dict[str, np.ndarray]:
        res = self.cfg.initial_resolution
        shape = (res,) * self.dim
        rng = np.random.default_rng(seed)
        color = rng.normal(0, 0.01, shape + (3 * self.cfg.color_coeffs,)).astype(np.float32)
        return {"density": np.full(shape, self.cfg.density_init / self.cfg.density_scale, np.float32), "color": color}

    def init_params(self, seed: int = 0) -> dict:
        return self.from_numpy(self.init_numpy(seed))

    def resolution_of(self, params) -> int:
        return int(round(dr.width(params["density"]) ** (1.0 / self.dim)))

    def to_numpy(self, params) -> dict:
        res = self.resolution_of(params)
        shape = (res,) * self.dim
        return {"density": np.asarray(params["density"]).reshape(shape),
                "color": np.asarray(params["color"]).reshape(shape + (3 * self.cfg.color_coeffs,))}

    def from_numpy(self, arrays) -> dict:
        return {"density": Float(np.asarray(arrays["density"], np.float32).ravel()),
                "color": Float(np.asarray(arrays["color"], np.float32).ravel())}

    # ------------------------------------------------------------------ evaluation
    def _sigma(self, params, corners, inside):
        raw = interpolate(params["density"], 1, corners)[0] * self.cfg.density_scale
        return dr.select(inside, density_activation(raw, self.cfg.density_activation), 0.0)

    def density(self, params, x) -> Float:
        corners, inside = corner_weights(list(x), self.cfg.bound, self.resolution_of(params))
        return self._sigma(params, corners, inside)

    def query(self, params, x, d):
        corners, inside = corner_weights(list(x), self.cfg.bound, self.resolution_of(params))
        sigma = self._sigma(params, corners, inside)
        K = self.cfg.color_coeffs
        coef = interpolate(params["color"], 3 * K, corners)
        if K == 1:
            raw = coef
        else:
            basis = view_basis(list(d), self.cfg.sh_degree)
            raw = [sum(coef[c * K + k] * basis[k] for k in range(K)) for c in range(3)]
        return sigma, [sigmoid(r) for r in raw]

    # ------------------------------------------------------------------ training hooks
    def resize(self, params, res: int) -> dict:
        """Resample both grids to ``res`` vertices per axis (coarse to fine)."""
        old = self.resolution_of(params)
        if res == old:
            return params
        axis = [np.linspace(-self.cfg.bound, self.cfg.bound, res, dtype=np.float32)] * self.dim
        pts = [Float(v.ravel()) for v in np.meshgrid(*axis, indexing="ij")[::-1]]   # x fastest
        corners, _ = corner_weights(pts, self.cfg.bound, old)
        C = 3 * self.cfg.color_coeffs
        with dr.suspend_grad():
            dens = interpolate(dr.detach(params["density"]), 1, corners)[0]
            col = interpolate(dr.detach(params["color"]), C, corners)
            col_flat = dr.zeros(Float, dr.width(pts[0]) * C)
            idx = dr.arange(UInt32, dr.width(pts[0]))
            for c in range(C):
                dr.scatter(col_flat, col[c], idx * C + c)
            dr.eval(dens, col_flat)
        return {"density": dens, "color": col_flat}

    def schedule(self, step: int, params) -> dict | None:
        """New parameters when the coarse-to-fine schedule changes the resolution at ``step``."""
        res = self.cfg.resolution_at(step)
        return self.resize(params, res) if res != self.resolution_of(params) else None

    def regularizer(self, params, seed: UInt32) -> Float | None:
        cfg = self.cfg
        if cfg.tv_weight <= 0 and cfg.tv_color_weight <= 0:
            return None
        res = self.resolution_of(params)
        n = res ** self.dim
        if cfg.tv_samples and cfg.tv_samples < n:
            v = hash_u32(hash_u32(seed ^ 0x2545F491) ^ dr.arange(UInt32, cfg.tv_samples)) % n
        else:
            v = dr.arange(UInt32, n)
        total = Float(0.0)
        for name, weight, C in (("density", cfg.tv_weight, 1), ("color", cfg.tv_color_weight, 3 * cfg.color_coeffs)):
            if weight <= 0:
                continue
            tv, stride = Float(0.0), 1
            for a in range(self.dim):
                coord = (v // stride) % res
                ok = coord < res - 1
                nb = dr.select(ok, v + stride, v)
                for c in range(C):
                    diff = dr.gather(Float, params[name], nb * C + c) - dr.gather(Float, params[name], v * C + c)
                    tv += dr.mean(dr.select(ok, diff * diff, 0.0))
                stride *= res
            scale = cfg.density_scale ** 2 if name == "density" else 1.0
            total = total + weight * scale * tv
        return total
