"""What every field offers the renderer, and the activations they share.

A field is *structure*; its trainable *storage* is a ``params`` dict of Dr.Jit arrays
held by the caller (an optimizer), as in ``drjit.nn``. Every field implements::

    init_numpy(seed) -> arrays           # initial weights, canonical numpy (both engines start here)
    init_params(seed) -> params          # new storage: from_numpy(init_numpy(seed))
    density(params, x) -> sigma          # x: D arrays [n] (world units) -> Float [n]
    query(params, x, d) -> (sigma, rgb)  # d: unit view directions -> Float [n], 3 x Float [n]
    to_numpy(params) / from_numpy(arrays)   # canonical weights (checkpoints, the torch twin)

A field with ``skips_color = True`` takes ``query(params, x, d, keep=None)``: ``keep`` maps the density to the
samples whose colour the integral uses (a Bool array), and the field may skip the colour's work elsewhere (and
return anything there), as the dense grid does.

``traceable`` says whether ``query`` can run inside a symbolic loop (one ray step at a
time, as the fused volume integral does); fields built on tensor matrix products
cannot, and are evaluated on all samples at once instead.
"""

from __future__ import annotations

import dataclasses

import drjit as dr
from drjit.auto.ad import Float

from ..errors import ConfigError, check_number

_DENSITY = {
    "relu": lambda raw: dr.maximum(raw, 0.0),                                         # NeRF
    "softplus": lambda raw: dr.maximum(raw, 0.0) + dr.log(1.0 + dr.exp(-dr.abs(raw))),  # mip-NeRF, finite for large x
    "trunc_exp": lambda raw: dr.exp(dr.minimum(raw, 15.0)),      # instant-ngp: clamped at e^15, gradients stay finite
}
DENSITY_ACTIVATIONS = tuple(_DENSITY)


class Field:
    """The parts of the protocol above that every field shares."""

    def __init__(self, cfg):
        self.cfg, self.dim = cfg, cfg.dim

    def init_params(self, seed: int = 0) -> dict:
        return self.from_numpy(self.init_numpy(seed))


def check_types(cfg) -> None:
    """Refuse a setting of the wrong type (a string where a number goes, a number where a
    flag goes), read from the config's annotations: a checkpoint or ``--set`` could carry one."""
    for f in dataclasses.fields(cfg):
        v, kind = getattr(cfg, f.name), str(f.type)
        if v is None and "None" in kind:
            continue
        if kind == "bool" and not isinstance(v, bool):
            raise ConfigError(f"{f.name} must be true or false, got {v!r}")
        if kind.startswith(("int", "float")):
            check_number(f.name, v, integer=kind.startswith("int"))
        if kind == "tuple" and not (isinstance(v, (tuple, list)) and all(
                isinstance(e, (int, float)) and not isinstance(e, bool) for e in v)):
            raise ConfigError(f"{f.name} must be a list of numbers, got {v!r}")
        if kind == "str" and not isinstance(v, str):
            raise ConfigError(f"{f.name} must be a string, got {v!r}")


def check_config(cfg, **ranges) -> None:
    """Validate the settings every field config has (``dim``, ``density_activation``,
    ``bound``), the types of all, and the integer settings in ``ranges`` (``name=(lo, hi)``)."""
    check_types(cfg)
    if cfg.dim not in (2, 3):
        raise ConfigError(f"dim must be 2 or 3, got {cfg.dim!r}")
    if cfg.density_activation not in DENSITY_ACTIVATIONS:
        raise ConfigError(f"density_activation must be one of {', '.join(DENSITY_ACTIVATIONS)}, "
                          f"got {cfg.density_activation!r}")
    check_number("bound", cfg.bound, 0, 1e6, strict_lo=True)
    for name, (lo, hi) in ranges.items():
        check_number(name, getattr(cfg, name), lo, hi, integer=True, flag=f"--{name.replace('_', '-')}")


def density_activation(raw, kind: str):
    """Raw network output -> density >= 0 (same formulas in the torch twin)."""
    if kind not in _DENSITY:
        raise ValueError(f"unknown density activation {kind!r}; choose one of {', '.join(DENSITY_ACTIVATIONS)}")
    return _DENSITY[kind](raw)


def cell_corners(i0: list, frac: list):
    """The ``2^D`` corners of the cells at integer coordinates ``i0`` (D arrays) for points at
    fractions ``frac`` of them: ``(coordinates, bi/trilinear weight)``; corner bit ``a`` steps along axis ``a``."""
    for c in range(1 << len(i0)):
        bits = [(c >> a) & 1 for a in range(len(i0))]
        weight = Float(1.0)
        for f, bit in zip(frac, bits):
            weight = weight * (f if bit else 1.0 - f)
        yield [i + bit for i, bit in zip(i0, bits)], weight


def sigmoid(x):
    return dr.rcp(1.0 + dr.exp(-x))
