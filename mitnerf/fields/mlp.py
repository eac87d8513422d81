"""The vanilla NeRF field (Mildenhall et al. 2020) for 2D and 3D scenes.

gamma_L(x / bound) (:mod:`.encoding`) feeds a ReLU trunk (``depth`` x ``width``, the encoding
concatenated again before layer ``skip``), a linear density head, and a ``width/2`` ReLU colour
branch on [trunk features, encoded view direction] to a sigmoid RGB.

Three modes compute the same function, named by the recipe (nothing chooses by machine): ``coopvec``,
cooperative vectors run per ray step inside the fused march (``traceable``); ``tensor``, GEMMs on feature-major
tensors (:func:`.layers.dense`); ``native``, a C kernel (:mod:`.native`; it needs a C compiler, and a step through
it cannot be frozen). The last two evaluate all samples at once. ``step_time/w128`` and ``step_time/w32``
(``benchmarks/step_time.py``) measure each mode's MLP part (``mlp_ms``) against the machine's peak. Canonical
weights are named and shaped as PyTorch's ``nn.Linear`` (``trunk.0.weight`` is ``[out, in]``).
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import numpy as np
from drjit.auto.ad import Float

from ..errors import ConfigError, EnvironmentProblem
from ..settings import setting
from .base import Field, FieldConfig, density_activation, sigmoid
from .encoding import direction_encoding, encoded_size, positional_encoding
from .layers import LinearLayers, torch_default_init
from .native import Stashes, library, native_mlp

MODES = ("native", "coopvec", "tensor")


@dataclass
class NeRFConfig(FieldConfig):
    """Architecture of the vanilla field."""

    pos_L: int = setting(8, lo=0, hi=24, flag="--pos-L")
    """Frequencies of the positional encoding (0: raw coordinates only)."""
    dir_L: int = setting(4, lo=0, hi=12, flag="--dir-L")
    """Frequencies of the view-direction encoding (2D: angle harmonics 1, 2, .., 2^(L-1))."""
    depth: int = setting(4, lo=1, hi=32, flag="--mlp-depth")
    """MLP trunk layers (NeRF: 8; NeRF2D: 6)."""
    width: int = setting(64, lo=2, hi=1024, flag="--mlp-width")
    """MLP units per layer (the colour branch has width / 2)."""
    skip: int | None = setting(None, lo=-1, hi=31)
    """Trunk layer that also receives the encoded position (NeRF: 4 of 8); None: depth // 2
    when depth >= 4, else no skip; -1: no skip."""
    view_dependent: bool = setting(True, flag="--view-dependence")
    """Feed the encoded view direction to the colour branch."""
    pe_window: int = setting(0, lo=0, hi=10 ** 9, unit="steps")
    """FreeNeRF's frequency regularisation: the positional encoding's frequencies open one after another, linearly,
    over the first ``pe_window`` steps of training (frequency k fully open at step ``(k + 1) pe_window / pos_L``),
    so the field fits coarse structure before fine; 0: all open from the start."""
    density_bias: float = setting(-1.0, lo=-1e3, hi=1e3)
    """Added to the density head's initial bias: a slightly transparent start."""
    mode: str = setting("tensor", choices=MODES)
    """``native``, ``coopvec`` or ``tensor`` (see the module docstring)."""

    def settle(self) -> None:
        """The skip layer's default, within the trunk; view dependence needs direction frequencies."""
        if self.skip is None:
            self.skip = self.depth // 2 if self.depth >= 4 else -1
        if self.skip > self.depth - 1:
            raise ConfigError(f"--set skip={self.skip}: the trunk has layers 0 to {self.depth - 1} (-1: no skip)")
        if self.view_dependent and self.dir_L < 1:
            raise ConfigError("a view-dependent field needs dir_L >= 1 (or set view_dependent=False)")


def layer_shapes(cfg: NeRFConfig) -> list[tuple[str, int, int]]:
    """``(name, out_features, in_features)`` of every linear layer, in canonical order."""
    enc = encoded_size(cfg.dim, cfg.pos_L)
    dir_in = encoded_size(cfg.dim, cfg.dir_L, direction=True) if cfg.view_dependent else 0
    trunk = [(f"trunk.{i}", cfg.width, enc if i == 0 else cfg.width + (enc if i == cfg.skip else 0))
             for i in range(cfg.depth)]
    return trunk + [("sigma", 1, cfg.width), ("color.0", cfg.width // 2, cfg.width + dir_in),
                    ("color.1", 3, cfg.width // 2)]


def init_weights(cfg: NeRFConfig, seed: int) -> dict[str, np.ndarray]:
    """PyTorch's ``nn.Linear`` default, U(-1/sqrt(in), 1/sqrt(in)) for weights and biases,
    drawn from numpy so that both backends can start from identical weights."""
    out = torch_default_init(layer_shapes(cfg), np.random.default_rng(seed))
    out["sigma.bias"] += np.float32(cfg.density_bias)
    return out


class NeRFField(Field):
    def __init__(self, cfg: NeRFConfig):
        super().__init__(cfg)
        self.mode = cfg.mode
        self.traceable, self.freezable = self.mode == "coopvec", self.mode != "native"   # C calls cannot be recorded
        self.layers = LinearLayers(layer_shapes(cfg), self.mode)
        self.stashes = Stashes()        # the native kernel's activation memory, reused step after step

    def init_numpy(self, seed: int = 0) -> dict[str, np.ndarray]:
        return init_weights(self.cfg, seed)

    def from_numpy(self, arrays: dict[str, np.ndarray]) -> dict:
        if self.mode == "native" and library() is None:       # storage for a kernel that cannot run here
            raise EnvironmentProblem("mode=native needs a working C compiler (cc, gcc or $CC) and none built the "
                                     "native MLP here: install one, or choose --set mode=tensor")
        return self.layers.from_numpy(arrays)

    def to_numpy(self, params: dict) -> dict[str, np.ndarray]:
        return self.layers.to_numpy(params)

    def density(self, params: dict, x) -> Float:
        return self.query(params, x, None)[0]

    def query(self, params: dict, x, d, keep=None):
        """Density and colour at ``x`` seen along ``d``; ``d=None`` (:meth:`density`): the colour is not wanted."""
        cfg, L = self.cfg, self.layers
        step = params.get("step") if cfg.pe_window else None
        opened = None if step is None else step * (cfg.pos_L / cfg.pe_window)
        enc_x = positional_encoding([xi * (1.0 / cfg.bound) for xi in x], cfg.pos_L, opened)
        if self.mode == "native" and d is None:     # the kernel wants a direction; it does not change the density
            d = [dr.zeros(Float, dr.width(x[0]))] + [dr.full(Float, 1.0, dr.width(x[0]))] * (cfg.dim - 1)
        enc_d = direction_encoding(list(d), cfg.dir_L) if cfg.view_dependent and d is not None else []
        if self.mode == "native":
            raw_sigma, raw_rgb = native_mlp(params["mlp"], enc_x, enc_d, (cfg.depth, cfg.width, cfg.skip),
                                          self.stashes)
            return density_activation(raw_sigma, cfg.density_activation), [sigmoid(v) for v in raw_rgb]
        h = L.start(enc_x)
        for i in range(cfg.depth):
            if i == cfg.skip and i > 0:
                h = L.concat(h, enc_x)
            h = L.linear(params, f"trunk.{i}", h, relu=True)
        sigma = density_activation(L.split(L.linear(params, "sigma", h, relu=False), 1)[0], cfg.density_activation)
        if d is None:
            return sigma, None
        c = L.linear(params, "color.0", L.concat(h, enc_d), relu=True)
        return sigma, [sigmoid(v) for v in L.split(L.linear(params, "color.1", c, relu=False), 3)]
