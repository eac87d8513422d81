r"""Renders without gradients, the colour deferred: a march of the density alone, then the colour of the samples
that keep it, packed.

The result is the volume integral of :mod:`.integral` (the same :math:`w_i = T_i \alpha_i`, the same rule that a
sample adds colour only where :math:`w_i > w_{min}`, the same end of each march where :math:`T` falls to ``stop``),
computed in another order:

1. **March** (one symbolic loop, one sample per ray per step, rays grouped by their sample count as in
   :class:`.integral.VolumeIntegral`): the density :math:`\sigma_i` only, accumulating :math:`T` and
   :math:`D = \sum_i w_i t_i` and counting the samples kept (:math:`w_i > w_{min}`): the :math:`k`-th kept sample
   of a ray writes :math:`w_i` and :math:`i` to its slot ``ray * N + k`` (the slots past a ray's count are never
   read).
2. **Pack**: the kept samples, ray-major in one array: each ray that keeps any writes its index where its samples
   start (the prefix sum of the counts), and a running maximum carries it over the rest; the work is per ray and
   per kept sample (a ray's few samples on its surface, usually), never per slot.
3. **Colour**: the field at the packed samples, every SIMD lane busy; then per ray
   :math:`C = \sum_i w_i c_i + T_N c_{bg}`, summed front to back over its packed samples (no atomic adds: the
   same render every run), and :math:`A = 1 - T_N`.

In the fused march, a field whose colour is many reads (a lattice of view harmonics: 12 floats or more at 8
corners) reads it for a packet of lanes wherever one lane of the packet keeps its sample; here only kept samples are
read, in full packets. The products :math:`w_i c_i` are rounded before they are summed, so the renders agree with
the fused march's to rounding (``tests/test_deferred.py``); the render's time: ``benchmarks/render.py``. It holds
two numbers per slot (``[n_rays N]``: :math:`w` and :math:`i`) besides the sampler's. :func:`.volume.volume_render`
takes this path for a traceable field that skips colour (``skips_color``), rendering without gradients and without
weights. Twin: the integral's (:mod:`mitnerf.reference.render.volume`), which computes the same result.
"""

from __future__ import annotations

from typing import Callable

import drjit as dr
from drjit.auto.ad import Float, UInt32

from .integral import RenderOutput, in_lanes, in_rays, marching
from .samplers import by_count, per_sample


def render_deferred(density: Callable, query: Callable, origins: list, directions: list, near: Float, far: Float,
                    sampler, background, w_min: float, stop: float) -> RenderOutput:
    """Rays ``origins, directions`` (D arrays ``[n_rays]``) through a field given as ``density(x, d) -> sigma`` and
    ``query(x, d) -> (sigma, rgb)`` (world points; sigma per unit of distance) -> colour, depth and opacity
    (no weights). ``sampler``: any sampler of :mod:`.samplers`; ``w_min``, ``stop``: see the module docstring."""
    n, N = dr.width(origins[0]), sampler.n
    order = by_count(sampler)
    ray = dr.arange(UInt32, n) if order is None else order            # lane -> ray
    o, d = in_lanes(origins, order), in_lanes(directions, order)
    near_r, far_r = per_sample(near, ray), per_sample(far, ray)
    kept, which = dr.empty(Float, n * N), dr.empty(UInt32, n * N)   # slot k of a ray: its k-th kept w_i, and i

    def body(i, T, D, k):
        t, delta = sampler.interval(ray, i, near_r, far_r)
        sigma = density([oi + t * di for oi, di in zip(o, d)], d)
        alpha = 1.0 - dr.exp(-sigma * delta)
        w = T * alpha
        keep = w > w_min
        dr.scatter(kept, w, ray * N + k, keep)
        dr.scatter(which, i, ray * N + k, keep)
        return i + 1, T * (1.0 - alpha), D + w * t, k + dr.select(keep, 1, 0)

    state = (UInt32(0), dr.full(Float, 1.0, n), dr.zeros(Float, n), dr.zeros(UInt32, n))
    _, T, D, count = dr.while_loop(state, marching(sampler, stop, ray), body, label="deferred_march")
    T, D, count = in_rays([T, D, count], order)
    dr.eval(kept, which, T, D, count)

    upto = dr.cumsum(count)                                            # per ray, the kept samples up to its own
    total = int(dr.gather(UInt32, upto, n - 1)[0]) if n else 0
    C = _colours(query, origins, directions, near, far, sampler, kept, which, upto, count, total) if total else \
        [dr.zeros(Float, n) for _ in range(3)]                         # no sample kept: the background
    return RenderOutput([c + T * b for c, b in zip(C, background)], D, 1.0 - T)


def _colours(query, origins, directions, near, far, sampler, kept, which, upto, count, total) -> list:
    r"""Per ray, :math:`\sum_i w_i c_i` over its kept samples: slot ``ray * N + k`` of ``kept`` and ``which`` holds
    the :math:`w_i` and :math:`i` of its :math:`k`-th; ``count`` how many each ray has, ``upto`` their inclusive
    prefix sum, ``total`` its last."""
    N, n = sampler.n, dr.width(count)
    start = upto - count                                               # exclusive
    r = dr.zeros(UInt32, total)                                        # packed sample -> its ray
    dr.scatter(r, dr.arange(UInt32, n), start, count > 0)
    r = dr.prefix_reduce(dr.ReduceOp.Max, r, exclusive=False)
    slot = r * N + dr.arange(UInt32, total) - dr.gather(UInt32, start, r)
    t, _ = sampler.interval(r, dr.gather(UInt32, which, slot), per_sample(near, r), per_sample(far, r))
    dk = [dr.gather(Float, di, r) for di in directions]
    _, rgb = query([dr.gather(Float, oi, r) + t * di for oi, di in zip(origins, dk)], dk)
    w = dr.gather(Float, kept, slot)
    wc = [w * ci for ci in rgb]
    dr.eval(wc)

    def add(j, C):                  # front to back over a ray's packed samples (deterministic: no atomic adds)
        return j + 1, [c + dr.gather(Float, v, start + j) for c, v in zip(C, wc)]

    return dr.while_loop((UInt32(0), [dr.zeros(Float, n) for _ in range(3)]), lambda j, C: j < count, add,
                         label="deferred_sum")[1]
