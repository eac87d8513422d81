"""Multi-resolution hash-grid field (Mueller et al. 2022, instant-ngp) for 2D and 3D.

Positions, mapped to ``[0, 1]^D`` over ``[-bound, bound]^D``, are encoded by a hash encoding
(:mod:`.hashenc`: ``drjit.nn.HashGridEncoding``'s function and table layout, in a step that freezes). A
one-hidden-layer density network maps the features to the raw density and ``geo_features``
features; a colour network maps those (plus the encoded view direction when ``view_dependent``)
to a sigmoid RGB. Outside the bound the density is 0. Twin: :mod:`mitnerf.reference.fields.hashgrid`.

Nothing ties a hashed entry to its neighbours, so on few views the field can fit the training rays without
the space between them: its test PSNR falls further below its training-view PSNR than the dense grid's, and
more steps do not close that gap (``hashgrid/generalisation`` in ``benchmarks/hashgrid_profile.py`` measures
both at equal steps). The learning rate acts as a regulariser: a lower one fits the training views better and
the test views worse, so the 2D recipe's is high.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import numpy as np
from drjit.auto.ad import Float

from ..errors import CheckpointError, ConfigError
from ..settings import setting
from .base import DENSITY_ACTIVATIONS, Field, FieldConfig, density_activation, sigmoid
from .encoding import direction_encoding, encoded_size
from .hashenc import hash_encode, hash_layout
from .layers import LinearLayers, torch_default_init


@dataclass
class HashGridConfig(FieldConfig):
    """A hash-grid encoding and two tiny networks."""

    n_levels: int = setting(12, lo=1, hi=32)
    """Resolution levels."""
    features_per_level: int = setting(2, lo=1, hi=8)
    """Features stored per vertex and level."""
    log2_hashmap_size: int = setting(15, lo=4, hi=24)
    """Entries per level (as a power of two); coarser levels that fit are stored densely."""
    base_resolution: int = setting(8, lo=2, hi=1 << 16)
    """Vertices per axis of the coarsest level."""
    max_resolution: int = setting(1024, lo=2, hi=1 << 20)
    """Vertices per axis of the finest level (sets the per-level scale)."""
    hidden: int = setting(32, lo=1, hi=512)
    """Width of the hidden layer of each network."""
    geo_features: int = setting(15, lo=1, hi=128)
    """Features passed from the density network to the colour network."""
    view_dependent: bool = setting(False, flag="--view-dependence")
    """Feed the encoded view direction to the colour network."""
    dir_L: int = setting(4, lo=0, hi=12, flag="--dir-L")
    """View-direction encoding frequencies."""
    density_activation: str = setting("trunc_exp", choices=DENSITY_ACTIVATIONS,
                                      flag="--density-activation")
    """As every field's, instant-ngp's by default."""
    density_bias: float = setting(-1.0, lo=-1e3, hi=1e3)
    """Added to the density output's initial bias."""
    init_scale: float = setting(1e-4, lo=0, hi=1)
    """Hash table entries start uniform in [-init_scale, init_scale]."""
    mode: str = setting("tensor", choices=("coopvec", "tensor"))
    """Network evaluation: ``coopvec`` (traceable: fused into the march) or ``tensor``."""

    def settle(self) -> None:
        if self.max_resolution < self.base_resolution:
            raise ConfigError(f"--set max_resolution={self.max_resolution} is below base_resolution "
                              f"({self.base_resolution}); the finest level is the largest")

    @property
    def per_level_scale(self) -> float:
        ratio = self.max_resolution / self.base_resolution
        return 1.0 if self.n_levels == 1 else float(np.exp(np.log(ratio) / (self.n_levels - 1)))


class HashGridField(Field):
    def __init__(self, cfg: HashGridConfig):
        super().__init__(cfg)
        self.traceable = cfg.mode == "coopvec"
        self.layout = hash_layout(cfg.dim, cfg.n_levels, cfg.features_per_level, 2 ** cfg.log2_hashmap_size,
                                  cfg.base_resolution, cfg.per_level_scale)
        n_feat = cfg.n_levels * cfg.features_per_level
        dir_in = encoded_size(cfg.dim, cfg.dir_L, direction=True) if cfg.view_dependent else 0
        self.shapes = [("sigma_net.0", cfg.hidden, n_feat), ("sigma_net.1", 1 + cfg.geo_features, cfg.hidden),
                       ("color_net.0", cfg.hidden, cfg.geo_features + dir_in), ("color_net.1", 3, cfg.hidden)]
        self.layers = LinearLayers(self.shapes, cfg.mode)

    @property
    def n_table(self) -> int:
        return self.layout.n_params

    def init_numpy(self, seed: int = 0) -> dict[str, np.ndarray]:
        rng = np.random.default_rng(seed)
        arrays = torch_default_init(self.shapes, rng)
        arrays["sigma_net.1.bias"][0] += np.float32(self.cfg.density_bias)
        arrays["table"] = rng.uniform(-self.cfg.init_scale, self.cfg.init_scale, self.n_table).astype(np.float32)
        return arrays

    def from_numpy(self, arrays: dict) -> dict:
        table = np.asarray(arrays["table"], np.float32).ravel()
        if table.size != self.n_table:
            raise CheckpointError(f"hash table has {table.size} entries, this configuration needs {self.n_table}; "
                                  "the checkpoint was saved with another configuration")
        return {"table": Float(table), **self.layers.from_numpy(arrays)}

    def to_numpy(self, params: dict) -> dict:
        return {"table": np.asarray(params["table"]), **self.layers.to_numpy(params)}

    def _sigma_and_geo(self, params, x):
        L, b = self.layers, self.cfg.bound
        unit = [dr.clip((xi * (1.0 / b) + 1.0) * 0.5, 0.0, 1.0) for xi in x]
        h = L.linear(params, "sigma_net.0", L.start(hash_encode(params["table"], unit, self.layout)), relu=True)
        out = L.linear(params, "sigma_net.1", h, relu=False)
        inside = dr.all([dr.abs(xi) <= b for xi in x])
        sigma = dr.select(inside, density_activation(L.split(out, 1)[0], self.cfg.density_activation), 0.0)
        return sigma, out

    def density(self, params: dict, x) -> Float:
        return self._sigma_and_geo(params, list(x))[0]

    def query(self, params: dict, x, d, keep=None):
        L = self.layers
        sigma, out = self._sigma_and_geo(params, list(x))
        enc_d = direction_encoding(list(d), self.cfg.dir_L) if self.cfg.view_dependent else []
        h = L.linear(params, "color_net.0", L.start(L.split(out)[1:] + enc_d), relu=True)   # geo features + direction
        return sigma, [sigmoid(v) for v in L.split(L.linear(params, "color_net.1", h, relu=False), 3)]
