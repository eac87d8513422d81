"""The vanilla NeRF field (Mildenhall et al. 2020) for 2D and 3D scenes.

Positions (divided by ``bound``) go through gamma_L (:mod:`.encoding`) and a ReLU trunk
of ``depth`` layers of ``width``, with the encoded position concatenated again before
layer ``skip``. A linear density head gives sigma through the density activation;
the colour branch maps [trunk features, encoded view direction] (or the features
alone without view dependence) through ``width/2`` ReLU units to a sigmoid RGB.

Three evaluation modes compute the same function:

* ``coopvec``: ``drjit.nn`` cooperative vectors on one packed weight buffer. Runs per
  ray step inside a symbolic loop (``traceable``), so the fused volume integral never
  stores per-sample activations. Its weight gradient costs one atomic add per weight
  per SIMD packet on LLVM, which dominates as the width grows.
* ``tensor``: matrix products on feature-major ``[channels, n_samples]`` tensors
  (Dr.Jit's GEMM kernels, :mod:`.dense`), evaluated on all samples at once; faster
  for wide layers.
* ``native``: the whole MLP in a C kernel (:mod:`.native`) wrapped as a ``dr.CustomOp``
  on one flat weight buffer, evaluated on all samples at once; near the machine's GEMM
  peak (``benchmarks/step_time.py``).

``mode='auto'`` is :func:`auto_mode`: the native kernel where it builds, else cooperative
vectors up to ``COOPVEC_MAX_WIDTH`` and tensor GEMMs above (``benchmarks/step_time.py``
measures all three per width). Canonical weights are named and shaped as PyTorch's
``nn.Linear`` (``trunk.0.weight`` is ``[out, in]``).
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import numpy as np
from drjit.auto.ad import Float

from ..errors import ConfigError
from .base import check_config, check_types, density_activation, sigmoid
from .encoding import direction_encoding, encoded_size, positional_encoding
from .layers import LinearLayers, check_shapes, torch_default_init
from .native import library, native_mlp

MODES = ("auto", "native", "coopvec", "tensor")
COOPVEC_MAX_WIDTH = 16
"""Without the native kernel, the widest layer for which cooperative vectors beat tensor
GEMMs (their weight gradient issues one atomic per weight per SIMD packet; the crossover
is measured by ``benchmarks/step_time.py``)."""


def auto_mode(width: int) -> str:
    """The fastest mode available for layers of ``width`` (see the module docstring)."""
    if library() is not None:
        return "native"
    return "coopvec" if width <= COOPVEC_MAX_WIDTH else "tensor"


@dataclass
class NeRFConfig:
    """Architecture of the vanilla field."""

    dim: int = 2
    """2 (positions x, y; a view angle) or 3 (x, y, z; a unit view direction)."""
    pos_L: int = 8
    """Frequencies of the positional encoding (0: raw coordinates only)."""
    dir_L: int = 4
    """Frequencies of the view-direction encoding (2D: angle harmonics 1, 2, .., 2^(L-1))."""
    depth: int = 4
    """Trunk layers (NeRF: 8; NeRF2D: 6)."""
    width: int = 64
    """Units per trunk layer (the colour branch has width / 2)."""
    skip: int | None = None
    """Trunk layer that also receives the encoded position (NeRF: 4 of 8); None: depth // 2
    when depth >= 4, else no skip; -1: no skip."""
    view_dependent: bool = True
    """Feed the encoded view direction to the colour branch."""
    density_activation: str = "softplus"
    """``relu`` (NeRF), ``softplus`` (mip-NeRF) or ``trunc_exp`` (instant-ngp)."""
    density_bias: float = -1.0
    """Added to the density head's initial bias: a slightly transparent start."""
    bound: float = 1.5
    """Scene half-extent; positions are divided by it before encoding."""
    mode: str = "auto"
    """``coopvec``, ``tensor`` or ``auto`` (by width)."""

    def __post_init__(self):
        check_types(self)
        if self.skip is None:
            self.skip = self.depth // 2 if self.depth >= 4 else -1
        check_config(self, pos_L=(0, 24), dir_L=(0, 12), depth=(1, 32), width=(2, 1024), skip=(-1, self.depth - 1))
        if self.mode not in MODES:
            raise ConfigError(f"mode must be one of {', '.join(MODES)}, got {self.mode!r}")
        if self.view_dependent and self.dir_L < 1:
            raise ConfigError("a view-dependent field needs dir_L >= 1 (or set view_dependent=False)")

    @property
    def resolved_mode(self) -> str:
        if self.mode == "native" and library() is None:
            return auto_mode(self.width)            # no compiler: the pure Dr.Jit path
        return auto_mode(self.width) if self.mode == "auto" else self.mode


def layer_shapes(cfg: NeRFConfig) -> list[tuple[str, int, int]]:
    """``(name, out_features, in_features)`` of every linear layer, in canonical order."""
    enc = encoded_size(cfg.dim, cfg.pos_L)
    shapes = []
    for i in range(cfg.depth):
        fan_in = enc if i == 0 else cfg.width + (enc if i == cfg.skip else 0)
        shapes.append((f"trunk.{i}", cfg.width, fan_in))
    shapes.append(("sigma", 1, cfg.width))
    dir_in = encoded_size(cfg.dim, cfg.dir_L, direction=True) if cfg.view_dependent else 0
    shapes.append(("color.0", cfg.width // 2, cfg.width + dir_in))
    shapes.append(("color.1", 3, cfg.width // 2))
    return shapes


def init_weights(cfg: NeRFConfig, seed: int) -> dict[str, np.ndarray]:
    """PyTorch's ``nn.Linear`` default, U(-1/sqrt(in), 1/sqrt(in)) for weights and biases,
    drawn from numpy so that both backends can start from identical weights."""
    out = torch_default_init(layer_shapes(cfg), np.random.default_rng(seed))
    out["sigma.bias"] += np.float32(cfg.density_bias)
    return out


class NeRFField:
    """The vanilla field; see the module docstring."""

    def __init__(self, cfg: NeRFConfig):
        self.cfg = cfg
        self.dim = cfg.dim
        self.mode = cfg.resolved_mode
        self.traceable = self.mode == "coopvec"
        self.freezable = self.mode != "native"       # a frozen step cannot record a call into C
        self.shapes = layer_shapes(cfg)
        self.layers = None if self.mode == "native" else LinearLayers(self.shapes, self.mode)

    def init_numpy(self, seed: int = 0) -> dict[str, np.ndarray]:
        return init_weights(self.cfg, seed)

    def init_params(self, seed: int = 0) -> dict:
        return self.from_numpy(self.init_numpy(seed))

    def from_numpy(self, arrays: dict[str, np.ndarray]) -> dict:
        if self.layers is not None:
            return self.layers.from_numpy(arrays)
        check_shapes(self.shapes, arrays)
        return {"mlp": Float(np.concatenate([np.asarray(arrays[f"{n}.{k}"], np.float32).ravel()
                                             for n, _, _ in self.shapes for k in ("weight", "bias")]))}

    def to_numpy(self, params: dict) -> dict[str, np.ndarray]:
        if self.layers is not None:
            return self.layers.to_numpy(params)
        flat, out, at = np.asarray(params["mlp"]), {}, 0
        for name, o, i in self.shapes:
            out[f"{name}.weight"] = flat[at:at + o * i].reshape(o, i).copy()
            out[f"{name}.bias"] = flat[at + o * i:at + o * i + o].copy()
            at += o * i + o
        return out

    def density(self, params: dict, x) -> Float:
        sigma, _ = self._evaluate(params, x, None, color=False)
        return sigma

    def query(self, params: dict, x, d):
        return self._evaluate(params, x, d, color=True)

    def _evaluate(self, params, x, d, color: bool):
        cfg, L = self.cfg, self.layers
        enc_x = positional_encoding([xi * (1.0 / cfg.bound) for xi in x], cfg.pos_L)
        if L is None:                               # native: directions do not change the density
            d = d if d is not None else [dr.zeros(Float, dr.width(x[0]))] + [dr.full(Float, 1.0, dr.width(x[0]))] * (
                cfg.dim - 1)
            enc_d = direction_encoding(list(d), cfg.dir_L) if cfg.view_dependent else []
            raw_sigma, raw_rgb = native_mlp(params["mlp"], enc_x, enc_d, (cfg.depth, cfg.width, cfg.skip))
            return density_activation(raw_sigma, cfg.density_activation), [sigmoid(v) for v in raw_rgb]
        h = L.start(enc_x)
        for i in range(cfg.depth):
            if i == cfg.skip and i > 0:
                h = L.concat(h, enc_x)
            h = L.linear(params, f"trunk.{i}", h, relu=True)
        sigma = density_activation(L.split(L.linear(params, "sigma", h, relu=False), 1)[0], cfg.density_activation)
        if not color:
            return sigma, None
        enc_d = direction_encoding(list(d), cfg.dir_L) if cfg.view_dependent else []
        c = L.linear(params, "color.0", L.concat(h, enc_d), relu=True)
        rgb = [sigmoid(v) for v in L.split(L.linear(params, "color.1", c, relu=False), 3)]
        return sigma, rgb
