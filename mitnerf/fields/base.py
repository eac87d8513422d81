"""The contract between a field and the renderer and engines (:class:`Field`), and the activations fields share.

A field is *structure*; its trainable *storage* is a ``params`` dict of Dr.Jit arrays held by the caller (an
optimizer), as in ``drjit.nn``. Its canonical weights are numpy arrays (checkpoints, the torch twins). Its
capabilities are class or instance attributes of :class:`Field` with stated defaults; nothing probes for them.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass

import drjit as dr
import numpy as np
from drjit.auto.ad import Float, UInt32

from ..settings import check, setting

_DENSITY = {
    "relu": lambda raw: dr.maximum(raw, 0.0),                                         # NeRF
    "softplus": lambda raw: dr.maximum(raw, 0.0) + dr.log(1.0 + dr.exp(-dr.abs(raw))),  # mip-NeRF, finite for large x
    "trunc_exp": lambda raw: dr.exp(dr.minimum(raw, 15.0)),      # instant-ngp: clamped at e^15, gradients stay finite
}
DENSITY_ACTIVATIONS = tuple(_DENSITY)


@dataclass
class FieldConfig:
    """The settings every field has (each checked by its declaration, :mod:`mitnerf.settings`; a family's config
    adds its own), and the end of a coarse-to-fine schedule (none by default)."""

    dim: int = setting(2, choices=(2, 3))
    """2 or 3: the data's dimension."""
    density_activation: str = setting("softplus", choices=DENSITY_ACTIVATIONS,
                                      flag="--density-activation")
    """Raw output -> density: ``softplus`` (mip-NeRF), ``relu`` (NeRF) or ``trunc_exp`` (instant-ngp)."""
    bound: float = setting(1.5, lo=0, above=True, hi=1e6)
    """Half-extent of the region the field covers, ``[-bound, bound]^D`` in world units (set from the data)."""

    def __post_init__(self):
        check(self)
        self.settle()

    def settle(self) -> None:
        """Derive the settings left to their defaults from others, and check the rules that tie settings
        together (each setting alone is checked by its declaration)."""

    def final(self):            # this config at the end of its coarse-to-fine schedule (what its size is judged by)
        return self

    @property
    def schedule_end(self) -> int:              # the step of its last coarse-to-fine change (0: none)
        return 0


class Field(abc.ABC):
    """A function from positions ``x`` (D arrays ``[n]``, world units) and unit view directions ``d`` (D arrays
    ``[n]``) to density ``[n]`` and colour (3 arrays ``[n]``), with its storage held outside."""

    traceable: bool = False
    """``query`` can run inside a symbolic loop, one ray step at a time (the fused volume integral); otherwise
    the renderer evaluates it on all samples at once (fields built on tensor matrix products)."""
    skips_color: bool = False
    """``query`` honours ``keep`` (the renderer passes it only then): where ``keep(sigma)`` is False the colour
    is not used, and the field may skip its work there and return anything."""
    freezable: bool = True
    """A training step through the field can be recorded with ``dr.freeze``."""
    scattered: bool = False
    """The rays of a SIMD packet seldom touch the same parameters (a fine lattice): the adjoint's atomic scatter-adds
    (into arrays too large for a gradient copy per thread, :data:`~mitnerf.train.backend_drjit.EXPAND_BYTES`) then
    go without Dr.Jit's per-packet pre-reduction (``JitFlag.ScatterReduceLocal``), which costs more than it saves
    there; a network's weights, which every lane touches, keep it."""

    def __init__(self, cfg):
        self.cfg, self.dim, self.bound = cfg, cfg.dim, float(cfg.bound)    # bound: the half-extent it covers

    @abc.abstractmethod
    def init_numpy(self, seed: int = 0) -> dict[str, np.ndarray]: ...     # canonical; both engines start here
    @abc.abstractmethod
    def from_numpy(self, arrays: dict[str, np.ndarray]) -> dict: ...      # storage; refuses another configuration's
    @abc.abstractmethod
    def to_numpy(self, params: dict) -> dict[str, np.ndarray]: ...
    @abc.abstractmethod
    def density(self, params: dict, x: list) -> Float: ...                 # x: D x [n] -> sigma [n]
    @abc.abstractmethod
    def query(self, params: dict, x: list, d: list, keep=None) -> tuple[Float, list]: ...  # -> sigma, 3 x [n]

    def init_params(self, seed: int = 0) -> dict:
        return self.from_numpy(self.init_numpy(seed))

    def saved(self, name: str, values) -> np.ndarray:
        """Values that follow storage array ``name``'s layout (its Adam moments) as a checkpoint keeps them: the
        array in memory, unless the storage pads its records (:meth:`stored` reverses it)."""
        return np.asarray(values)

    def stored(self, name: str, values: np.ndarray) -> np.ndarray:
        """Values :meth:`saved` wrote, in storage array ``name``'s layout: flat float32."""
        return np.asarray(values, np.float32).ravel()

    def schedule(self, step: int, params: dict) -> dict | None:
        """New storage when the training schedule changes the field at ``step`` (a grid's resize), else None."""
        return None

    def regularizer(self, params: dict, seed: UInt32) -> Float | None:
        """A loss term on the storage (e.g. total variation), or None."""
        return None


def density_activation(raw, kind: str):
    """Raw network output -> density >= 0 (same formulas in the torch twin)."""
    if kind not in _DENSITY:
        raise ValueError(f"unknown density activation {kind!r}; choose one of {', '.join(DENSITY_ACTIVATIONS)}")
    return _DENSITY[kind](raw)


def cell_corners(i0: list, frac: list):
    """The ``2^D`` corners of the cells at integer coordinates ``i0`` (D arrays) for points at
    fractions ``frac`` of them: ``(coordinates, bi/trilinear weight)``; corner bit ``a`` steps along axis ``a``.
    Dr.Jit arrays or torch tensors alike (the twins' corner order)."""
    for c in range(1 << len(i0)):
        bits = [(c >> a) & 1 for a in range(len(i0))]
        weight = 1.0
        for f, bit in zip(frac, bits):
            weight = weight * (f if bit else 1.0 - f)
        yield [i + bit for i, bit in zip(i0, bits)], weight


def sigmoid(x):
    return dr.rcp(1.0 + dr.exp(-x))
