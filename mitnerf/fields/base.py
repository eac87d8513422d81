"""What every field offers the renderer, and the activations they share.

A field is *structure*; its trainable *storage* is a ``params`` dict of Dr.Jit arrays
held by the caller (an optimizer), as in ``drjit.nn``. Every field implements::

    init_params(seed) -> params          # new storage, deterministic for the seed
    density(params, x) -> sigma          # x: D arrays [n] (world units) -> Float [n]
    query(params, x, d) -> (sigma, rgb)  # d: unit view directions -> Float [n], 3 x Float [n]
    to_numpy(params) / from_numpy(arrays)   # canonical weights (checkpoints, the torch twin)

``traceable`` says whether ``query`` can run inside a symbolic loop (one ray step at a
time, as the fused volume integral does); fields built on tensor matrix products
cannot, and are evaluated on all samples at once instead.
"""

from __future__ import annotations

import drjit as dr

DENSITY_ACTIVATIONS = ("relu", "softplus", "trunc_exp")


def check_config(cfg) -> None:
    """Validate the fields every field config has: ``dim`` and ``density_activation``."""
    if cfg.dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {cfg.dim}")
    if cfg.density_activation not in DENSITY_ACTIVATIONS:
        raise ValueError(f"density_activation must be one of {DENSITY_ACTIVATIONS}, got {cfg.density_activation!r}")


def density_activation(raw, kind: str):
    """Raw network output -> density >= 0 (same formulas in the torch twin).

    ``relu`` as in NeRF; ``softplus`` as in mip-NeRF (smooth, never dead);
    ``trunc_exp`` as in instant-ngp: exp clamped at e^15 so gradients stay finite.
    """
    if kind == "relu":
        return dr.maximum(raw, 0.0)
    if kind == "softplus":   # log(1 + e^x), written to stay finite for large x
        return dr.maximum(raw, 0.0) + dr.log(1.0 + dr.exp(-dr.abs(raw)))
    if kind == "trunc_exp":
        return dr.exp(dr.minimum(raw, 15.0))
    raise ValueError(f"unknown density activation {kind!r}; choose one of {', '.join(DENSITY_ACTIVATIONS)}")


def sigmoid(x):
    return dr.rcp(1.0 + dr.exp(-x))
