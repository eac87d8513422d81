"""``volume_render``: one entry point from a field and rays to per-ray colour, depth, opacity.

``method='replay'`` uses the custom operation of :mod:`.integral` (the default);
``method='autodiff'`` the plain-AD integral of :mod:`.autodiff`. Traceable fields run
inside the march; others (tensor-mode MLPs) are evaluated on all samples first and
read back by the same operation.
"""

from __future__ import annotations

import drjit as dr
from drjit.auto.ad import Array3f, Float, UInt32

from .autodiff import integrate_autodiff
from .integral import FieldSource, GatheredSource, RenderOutput, VolumeIntegral

METHODS = ("replay", "autodiff")


def sample_points(origins: list, directions: list, t: Float, N: int):
    """Positions and directions of all samples (ray-major), each D arrays ``[n_rays * N]``."""
    ray = dr.arange(UInt32, dr.width(t)) // N
    d = [dr.gather(Float, di, ray) for di in directions]
    x = [dr.gather(Float, oi, ray) + t * di for oi, di in zip(origins, d)]
    return x, d


def volume_render(field, params: dict, origins: list, directions: list, near, far, sampler,
                  background=(0.0, 0.0, 0.0), *, method: str = "replay", weights: bool = False,
                  input_grads: bool = False) -> RenderOutput:
    """Render rays ``origins, directions`` (D arrays ``[n_rays]``; unit directions) through
    ``field`` with ``params``; ``near, far``: per-ray arrays or scalars.

    ``weights=True`` also returns the per-sample weights (differentiable: depth
    supervision uses them). ``input_grads=True`` makes origins and directions
    differentiable through a traceable field.
    """
    n = dr.width(origins[0])
    near, far = Float(near), Float(far)
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if method == "replay" and field.traceable:
        out = dr.custom(VolumeIntegral, params, list(origins), list(directions), near, far, FieldSource(field),
                        sampler, tuple(background), weights, input_grads)
        return RenderOutput(*out)
    t, delta = sampler.points(n, near, far)
    x, d = sample_points(origins, directions, t, sampler.n)
    sigma, rgb = field.query(params, x, d)
    if method == "autodiff":
        out = integrate_autodiff(sigma, rgb, t, delta, sampler.n, background)
        return out if weights else RenderOutput(out.rgb, out.depth, out.opacity)
    samples = {"sigma": sigma, "rgb": dr.ravel(Array3f(rgb))}
    out = dr.custom(VolumeIntegral, samples, list(origins), list(directions), near, far, GatheredSource(),
                    sampler, tuple(background), weights, False)
    return RenderOutput(*out)
