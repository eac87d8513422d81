"""Multi-resolution hash-grid field (Mueller et al. 2022, instant-ngp) for 2D and 3D.

Positions, mapped to ``[0, 1]^D`` over ``[-bound, bound]^D``, are encoded by a
multi-resolution hash encoding (:mod:`.hashenc`, the same function and table layout
as ``drjit.nn.HashGridEncoding``, which ``encoding='drjit'`` uses instead): ``n_levels`` grids from ``base_resolution`` to
``max_resolution`` vertices per axis (geometric progression), ``features_per_level``
features per vertex, dense where a level fits in ``2^log2_hashmap_size`` entries and
hashed beyond. A one-hidden-layer density network maps the features to the raw
density and ``geo_features`` features; a colour network maps those (plus the encoded
view direction when ``view_dependent``) to a sigmoid RGB. Outside the bound the
density is 0.

The encoding is a sum of gathers (traceable); the networks run as cooperative vectors
(then the whole field runs inside the fused march) or tensor-mode GEMMs
(:mod:`.layers`). Twin: :mod:`mitnerf.reference.fields.hashgrid`.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import drjit.nn as nn
import numpy as np
from drjit.auto.ad import Float

from ..errors import CheckpointError, ConfigError
from .base import check_config, density_activation, sigmoid
from .encoding import direction_encoding, encoded_size
from .hashenc import hash_encode, hash_layout
from .layers import LinearLayers, torch_default_init


@dataclass
class HashGridConfig:
    """A hash-grid encoding and two tiny networks."""

    dim: int = 2
    """2 or 3."""
    n_levels: int = 12
    """Resolution levels."""
    features_per_level: int = 2
    """Features stored per vertex and level."""
    log2_hashmap_size: int = 15
    """Entries per level (as a power of two); coarser levels that fit are stored densely."""
    base_resolution: int = 8
    """Vertices per axis of the coarsest level."""
    max_resolution: int = 1024
    """Vertices per axis of the finest level (sets the per-level scale)."""
    hidden: int = 32
    """Width of the hidden layer of each network."""
    geo_features: int = 15
    """Features passed from the density network to the colour network."""
    view_dependent: bool = False
    """Feed the encoded view direction to the colour network."""
    dir_L: int = 4
    """View-direction encoding frequencies."""
    density_activation: str = "trunc_exp"
    """``trunc_exp`` (instant-ngp), ``softplus`` or ``relu``."""
    density_bias: float = -1.0
    """Added to the density output's initial bias."""
    init_scale: float = 1e-4
    """Hash table entries start uniform in [-init_scale, init_scale]."""
    mode: str = "tensor"
    """Network evaluation: ``coopvec`` (traceable: fused into the march) or ``tensor``."""
    encoding: str = "mitnerf"
    """``mitnerf`` (:mod:`.hashenc`, scalar gathers) or ``drjit`` (``drjit.nn.HashGridEncoding``;
    with Dr.Jit 1.5.0 its training step cannot be frozen: train with ``freeze=False``)."""
    bound: float = 1.5
    """Half-extent of the encoded region in world units."""

    def __post_init__(self):
        check_config(self, n_levels=(1, 32), features_per_level=(1, 8), log2_hashmap_size=(4, 24),
                     base_resolution=(2, 1 << 16), max_resolution=(self.base_resolution, 1 << 20), hidden=(1, 512),
                     geo_features=(1, 128), dir_L=(0, 12))
        if self.mode not in ("coopvec", "tensor"):
            raise ConfigError(f"mode must be coopvec or tensor, got {self.mode!r}")
        if self.encoding not in ("mitnerf", "drjit"):
            raise ConfigError(f"encoding must be mitnerf or drjit, got {self.encoding!r}")

    @property
    def per_level_scale(self) -> float:
        if self.n_levels == 1:
            return 1.0
        return float(np.exp(np.log(self.max_resolution / self.base_resolution) / (self.n_levels - 1)))


class HashGridField:
    """See the module docstring."""

    def __init__(self, cfg: HashGridConfig):
        self.cfg = cfg
        self.dim = cfg.dim
        self.traceable = cfg.mode == "coopvec"
        self.layout = hash_layout(cfg.dim, cfg.n_levels, cfg.features_per_level, 2 ** cfg.log2_hashmap_size,
                                  cfg.base_resolution, cfg.per_level_scale)
        self.encoding = None
        if cfg.encoding == "drjit":
            self.encoding = nn.HashGridEncoding(
                Float, cfg.dim, n_levels=cfg.n_levels, n_features_per_level=cfg.features_per_level,
                hashmap_size=2 ** cfg.log2_hashmap_size, base_resolution=cfg.base_resolution,
                per_level_scale=cfg.per_level_scale, init_scale=cfg.init_scale, rng=dr.rng(seed=0))
        n_feat = cfg.n_levels * cfg.features_per_level
        dir_in = encoded_size(cfg.dim, cfg.dir_L, direction=True) if cfg.view_dependent else 0
        self.shapes = [("sigma_net.0", cfg.hidden, n_feat), ("sigma_net.1", 1 + cfg.geo_features, cfg.hidden),
                       ("color_net.0", cfg.hidden, cfg.geo_features + dir_in), ("color_net.1", 3, cfg.hidden)]
        self.layers = LinearLayers(self.shapes, cfg.mode)

    # ------------------------------------------------------------------ storage
    @property
    def n_table(self) -> int:
        return self.layout.n_params

    def init_numpy(self, seed: int = 0) -> dict[str, np.ndarray]:
        rng = np.random.default_rng(seed)
        arrays = torch_default_init(self.shapes, rng)
        arrays["sigma_net.1.bias"][0] += np.float32(self.cfg.density_bias)
        s = self.cfg.init_scale
        arrays["table"] = rng.uniform(-s, s, self.n_table).astype(np.float32)
        return arrays

    def init_params(self, seed: int = 0) -> dict:
        return self.from_numpy(self.init_numpy(seed))

    def from_numpy(self, arrays: dict) -> dict:
        table = np.asarray(arrays["table"], np.float32).ravel()
        if table.size != self.n_table:
            raise CheckpointError(f"hash table has {table.size} entries, this configuration needs {self.n_table}; "
                             "the checkpoint was saved with another configuration")
        return {"table": Float(table), **self.layers.from_numpy(arrays)}

    def to_numpy(self, params: dict) -> dict:
        return {"table": np.asarray(params["table"]), **self.layers.to_numpy(params)}

    # ------------------------------------------------------------------ evaluation
    def _features(self, params, x):
        b = self.cfg.bound
        inside = None
        unit = []
        for xi in x:
            ok = dr.abs(xi) <= b
            inside = ok if inside is None else inside & ok
            unit.append(dr.clip((xi * (1.0 / b) + 1.0) * 0.5, 0.0, 1.0))
        if self.encoding is None:
            return hash_encode(params["table"], unit, self.layout), inside
        self.encoding.data = params["table"]          # structure apart from storage: bind this call's table
        return list(self.encoding(unit)), inside

    def _sigma_and_geo(self, params, x):
        L = self.layers
        feat, inside = self._features(params, x)
        h = L.linear(params, "sigma_net.0", L.start(feat), relu=True)
        out = L.linear(params, "sigma_net.1", h, relu=False)
        sigma = dr.select(inside, density_activation(L.split(out, 1)[0], self.cfg.density_activation), 0.0)
        return sigma, out

    def density(self, params: dict, x) -> Float:
        return self._sigma_and_geo(params, list(x))[0]

    def query(self, params: dict, x, d):
        L = self.layers
        sigma, out = self._sigma_and_geo(params, list(x))
        geo = L.split(out)[1:]
        enc_d = direction_encoding(list(d), self.cfg.dir_L) if self.cfg.view_dependent else []
        h = L.linear(params, "color_net.0", L.start(geo + enc_d), relu=True)
        rgb = [sigmoid(v) for v in L.split(L.linear(params, "color_net.1", h, relu=False), 3)]
        return sigma, rgb
