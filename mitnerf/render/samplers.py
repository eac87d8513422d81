"""Where along each ray the field is sampled (Dr.Jit; twin: ``mitnerf.reference.render.samplers``).

A sampler gives every ray ``N`` intervals ``(t_i, delta_i)``, sorted in ``[near, far)``; contiguous ones
have ``delta_i = t_{i+1} - t_i`` with ``t_N = far``. A ``knee`` spaces them evenly in :func:`.space.to_s` (linear in
disparity past it: forward-facing and unbounded scenes) instead of in distance. ``interval(ray, i, near, far)`` answers one step (the
fused integral calls it in its loop and its replay), ``points()`` all samples at once. Jitter is the
counter-based hash ``uniform(seed, ray, i)`` of :mod:`mitnerf.rng`, identical in the twin.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
from drjit.auto.ad import Float, UInt32

from ..rng import uniform
from .space import to_s, to_t


class _Sampler:
    """Contiguous intervals from ``t(ray, i, near, far)`` (``t_n = far``)."""

    count = None
    """Per ray, the samples that can contribute (``UInt32``; the others have ``delta = 0``); None: all ``n``."""

    def interval(self, ray: UInt32, i: UInt32, near: Float, far: Float) -> tuple[Float, Float]:
        t = self.t(ray, i, near, far)
        return t, self.t(ray, i + 1, near, far) - t

    def points(self, n_rays: int, near: Float, far: Float) -> tuple[Float, Float]:
        """``t`` and ``delta`` of all samples, ray-major, each ``[n_rays * n]``."""
        idx = dr.arange(UInt32, n_rays * self.n)
        ray, i = idx // self.n, idx % self.n
        return self.interval(ray, i, per_sample(near, ray), per_sample(far, ray))


@dataclass
class Stratified(_Sampler):
    """One sample per equal bin of [near, far] (of its image under :func:`.space.to_s` with a ``knee``), at the bin
    centre or jittered in it."""

    n: int
    """Samples per ray."""
    seed: UInt32
    """Per-step seed (pass ``dr.opaque(UInt32, k)`` in frozen functions)."""
    jitter: bool = True
    """Jitter each sample inside its bin (training); centres otherwise."""
    knee: float | None = None
    """Distance past which the bins are even in disparity (:func:`.space.to_s`); None: even in distance."""

    def t(self, ray: UInt32, i: UInt32, near: Float, far: Float) -> Float:
        u = uniform(self.seed, ray, i) if self.jitter else Float(0.5)
        if self.knee is None:
            t = near + (Float(i) + u) * ((far - near) * (1.0 / self.n))
        else:
            lo, hi = (to_s(v, self.knee, dr.select) for v in (near, far))
            t = to_t(lo + (Float(i) + u) * ((hi - lo) * (1.0 / self.n)), self.knee, dr.select)
        return dr.select(i >= self.n, far, t)


@dataclass
class Explicit(_Sampler):
    """Given sorted distances per ray, ``t_flat [n_rays * n]`` (ray-major), and either given
    interval lengths ``delta_flat`` or contiguous ones (``t_{i+1} - t_i``, ``t_n = far``); ``count``: see
    :attr:`_Sampler.count`."""

    t_flat: Float
    n: int
    delta_flat: Float | None = None
    count: UInt32 | None = None
    filled: bool = True
    """Whether the slots past :attr:`count` hold ``t = far, delta = 0``; False: they hold anything, and
    :meth:`points` masks them."""

    def t(self, ray: UInt32, i: UInt32, near: Float, far: Float) -> Float:
        inside = i < self.n
        t = dr.gather(Float, self.t_flat, ray * self.n + dr.minimum(i, self.n - 1), inside)
        return dr.select(inside, t, far)

    def interval(self, ray: UInt32, i: UInt32, near: Float, far: Float) -> tuple[Float, Float]:
        if self.delta_flat is None:
            return super().interval(ray, i, near, far)
        return self.t(ray, i, near, far), dr.gather(Float, self.delta_flat, ray * self.n + i)

    def points(self, n_rays: int, near: Float, far: Float) -> tuple[Float, Float]:
        """As :meth:`_Sampler.points`; with a :attr:`count` and slots not :attr:`filled`, the slots past it read as
        ``t = far, delta = 0`` whatever they hold."""
        t, delta = super().points(n_rays, near, far)
        if self.count is None or self.filled:
            return t, delta
        idx = dr.arange(UInt32, n_rays * self.n)
        ray = idx // self.n
        used = idx % self.n < dr.gather(UInt32, self.count, ray)
        return dr.select(used, t, per_sample(far, ray)), dr.select(used, delta, 0.0)


def by_count(sampler) -> UInt32 | None:
    """The rays in the order a march takes them, grouped by :attr:`~_Sampler.count`; None where every ray has
    ``n`` samples. See :func:`grouped`."""
    return None if sampler.count is None else grouped(sampler.count, sampler.n)


def grouped(key: UInt32, top: int) -> UInt32:
    """A permutation (lane -> ray) that groups rays by ``key`` in ``[0, top]`` (a larger key counts as ``top``),
    ascending (a counting sort), for loops whose length per ray is ``key``: the lanes of a SIMD packet then end
    their loops together, where in any order a packet's loop runs on for its longest ray while the others idle.
    ``[n_rays]``; within a key the order is not fixed, and no result depends on it."""
    n, key = dr.width(key), dr.minimum(key, top)
    histogram = dr.zeros(UInt32, top + 1)
    slot = dr.scatter_inc(histogram, key)           # a ray's place among those of its key
    dr.eval(slot)
    order = dr.zeros(UInt32, n)
    place = dr.gather(UInt32, dr.prefix_sum(histogram), key) + slot
    dr.scatter(order, dr.arange(UInt32, n), place, mode=dr.ReduceMode.Permute)
    return order


def per_sample(value: Float, ray: UInt32) -> Float:
    """Broadcast a per-ray (or scalar) quantity to samples."""
    return value if dr.width(value) <= 1 else dr.gather(Float, value, ray)


def count_below(sorted_flat: Float, block: int, base: UInt32, query: Float, strict: bool = True) -> UInt32:
    """Per lane: how many of the ``block`` sorted values starting at ``base`` are ``< query``
    (``<= query`` when not ``strict``); ``searchsorted`` per ray, as a branchless binary search."""
    lo = dr.zeros(UInt32, dr.width(query))
    step = 1 << (block.bit_length() - 1)
    while step:
        cand = lo + step
        v = dr.gather(Float, sorted_flat, base + dr.minimum(cand, block) - 1)
        ok = (cand <= block) & ((v < query) if strict else (v <= query))
        lo = dr.select(ok, cand, lo)
        step >>= 1
    return lo


def importance_sample(t: Float, delta: Float, weights: Float, n_rays: int, n_coarse: int, n_fine: int,
                      seed: UInt32, jitter: bool) -> Explicit:
    """NeRF's hierarchical sampling: ``n_fine`` draws from the piecewise-constant density of the coarse
    ``weights`` on ``[t, t + delta)``, merged with the coarse samples (sorted, ``n_coarse + n_fine`` per ray,
    contiguous). Inputs ``[n_rays * n_coarse]``, detached."""
    Nc, Nf = n_coarse, n_fine
    w = dr.detach(weights) + 1e-5                     # never a zero-probability ray
    cdf = dr.block_prefix_sum(w, Nc, exclusive=False)
    total = dr.block_sum(w, Nc)
    idx = dr.arange(UInt32, n_rays * Nf)
    ray, j = idx // Nf, idx % Nf
    u = (Float(j) + (uniform(seed ^ 0x5BD1E995, ray, j) if jitter else 0.5)) * (1.0 / Nf)   # sorted in j
    target = u * dr.gather(Float, total, ray)
    base = ray * Nc
    k = dr.minimum(count_below(cdf, Nc, base, target), Nc - 1)      # bin whose cdf first reaches the target
    cdf_hi = dr.gather(Float, cdf, base + k)
    wk = dr.gather(Float, w, base + k)
    frac = dr.clip((target - (cdf_hi - wk)) / wk, 0.0, 1.0)
    t_new = dr.gather(Float, t, base + k) + frac * dr.gather(Float, delta, base + k)
    # merge the two sorted lists of each ray: an element's rank is its own index plus the
    # number of elements of the other list before it (ties: the coarse sample first)
    N = Nc + Nf
    cidx = dr.arange(UInt32, n_rays * Nc)
    cray, ci = cidx // Nc, cidx % Nc
    rank_c = ci + count_below(t_new, Nf, cray * Nf, t, strict=True)
    rank_f = j + count_below(t, Nc, base, t_new, strict=False)
    out = dr.zeros(Float, n_rays * N)
    dr.scatter(out, t, cray * N + rank_c, mode=dr.ReduceMode.Permute)
    dr.scatter(out, t_new, ray * N + rank_f, mode=dr.ReduceMode.Permute)
    return Explicit(out, N)
