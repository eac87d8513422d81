"""``volume_render``: from a field and rays to per-ray colour, depth, opacity.

``method='replay'`` (default) uses the custom operation of :mod:`.integral`; ``'autodiff'`` is the plain-AD
check :func:`integrate_autodiff` (also for forward mode), which stores every per-sample intermediate.
Non-traceable fields (tensor-mode MLPs) are evaluated on all samples first and read back by the same operation.
A render without gradients or weights (``stop`` > 0) of a traceable field that skips colour marches the density
alone and reads the colour of the kept samples afterwards, packed (:mod:`.deferred`): the same integral.
In a forward-facing or unbounded scene the field sees the warped points, and its density is stretched into density
per unit of world distance (:mod:`.space`).
"""

from __future__ import annotations

from dataclasses import replace

import drjit as dr
from drjit.auto.ad import Array3f, Float, UInt32

from .deferred import render_deferred
from .integral import W_MIN, RenderOutput, VolumeIntegral, gathered_source
from .space import DRJIT, Space

METHODS = ("replay", "autodiff")
DEFER_MAX_SLOTS = 1 << 26
"""Sample slots (rays x samples a ray) past which a render marches fused rather than deferred: the deferred colour
holds a float per slot (:mod:`.deferred`), 256 MiB at this many, where the fused march holds nothing per slot."""


def integrate_autodiff(sigma: Float, rgb: list, t: Float, delta: Float, N: int, background,
                       w_min: float = W_MIN) -> RenderOutput:
    """Ray-major samples (``[n_rays * N]`` each) -> per-ray colour, depth, opacity, weights; block
    prefix sums for the transmittance. Samples of weight at most ``w_min`` add no colour, as in the replay."""
    sd = sigma * delta
    T = dr.exp(-dr.block_prefix_sum(sd, N, exclusive=True))     # T_i
    w = T * (1.0 - dr.exp(-sd))
    T_end = dr.exp(-dr.block_sum(sd, N))
    C = [dr.block_sum(dr.select(w > w_min, w * c, 0.0), N) + T_end * b for c, b in zip(rgb, background)]
    return RenderOutput(C, dr.block_sum(w * t, N), 1.0 - T_end, w)


def volume_render(field, params: dict, origins: list, directions: list, near, far, sampler,
                  background=(0.0, 0.0, 0.0), *, method: str = "replay", weights: bool = False,
                  input_grads: bool = False, w_min: float = W_MIN, stop: float = 0.0,
                  space: Space = Space(), defer: bool = True) -> RenderOutput:
    """Render rays ``origins, directions`` (D arrays ``[n_rays]``; unit directions) through ``field``;
    ``near, far``: per-ray arrays or scalars. ``weights=True`` also returns the (differentiable) per-sample
    weights; ``input_grads=True`` makes origins and directions differentiable through a traceable field. Samples
    of weight at most ``w_min`` add no colour (:mod:`.integral`; 0: every sample's colour counts); ``stop`` > 0 ends
    a ray's march where its transmittance falls to it (renders without gradients). ``space``: the scene's warp
    (:mod:`.space`); ``defer``: such a render of a traceable field that skips colour reads the colour after the
    march (:mod:`.deferred`; False, or more than :data:`DEFER_MAX_SLOTS` slots: in it)."""
    near, far = Float(near), Float(far)
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")

    def query(p, x, d, keep=None):          # the field at world points: warped, its density stretched
        if not space.warped:
            return field.query(p, x, d, keep)
        x, stretch = space.warp(x, d, DRJIT)
        sigma, rgb = field.query(p, x, d, None if keep is None else (lambda s: keep(s * stretch)))
        return sigma * stretch, rgb

    deferred = (defer and stop > 0 and not (weights or input_grads)          # a render, with nothing else asked
                and dr.width(origins[0]) * sampler.n <= DEFER_MAX_SLOTS)
    if deferred and method == "replay" and field.traceable and field.skips_color:
        # the march's density: query's, whose colour no kernel then reads (unused values are never compiled)
        return render_deferred(lambda x, d: query(params, x, d)[0], lambda x, d: query(params, x, d), list(origins),
                               list(directions), near, far, sampler, tuple(background), float(w_min), float(stop))
    if method == "replay" and field.traceable:
        def source(p, x, d, index, keep=None):
            return query(p, x, d, keep if field.skips_color else None)
    else:
        t, delta = sampler.points(dr.width(origins[0]), near, far)
        ray = dr.arange(UInt32, dr.width(t)) // sampler.n                   # of every sample (ray-major)
        d = [dr.gather(Float, di, ray) for di in directions]
        sigma, rgb = query(params, [dr.gather(Float, oi, ray) + t * di for oi, di in zip(origins, d)], d)
        if method == "autodiff":
            out = integrate_autodiff(sigma, rgb, t, delta, sampler.n, background, w_min)
            return out if weights else replace(out, weights=None)
        params, source, input_grads = {"sigma": sigma, "rgb": dr.ravel(Array3f(rgb))}, gathered_source, False
    out = dr.custom(VolumeIntegral, params, list(origins), list(directions), near, far, source, sampler,
                    tuple(background), weights, input_grads, float(w_min), float(stop))
    return RenderOutput(*out)
