r"""Losses (Dr.Jit; twin: ``mitnerf.reference.train.losses``); per-sample inputs ``[n_rays * N]``, sorted per ray.

**Depth supervision (DS-NeRF).** The termination density :math:`h(t_i) \approx w_i / \delta_i` is pulled
towards :math:`q = \mathcal N(D, \hat\sigma^2)` around the measured depth *D* by minimising the KL estimate
:math:`\mathcal L_{depth} = \sum_i q(t_i)\, \delta_i \,[\log q(t_i) - \log(w_i / \delta_i + \epsilon)]`
(about 0 when the weights match the Gaussian, whatever the sampling). Rays that miss are left out.

**Distortion (mip-NeRF 360).** With midpoints :math:`m_i = t_i + \delta_i / 2`,
:math:`\mathcal L_{dist} = \sum_{i,j} w_i w_j |m_i - m_j| + \tfrac13 \sum_i w_i^2 \delta_i`, computed in O(N) as
:math:`2 \sum_i w_i (m_i W_i - S_i)` with the prefix sums :math:`W_i = \sum_{j<i} w_j, S_i = \sum_{j<i} w_j m_j`.

**Free space (line of sight, as Urban Radiance Fields' empty-space term).** Where the data says that a ray
crosses empty space up to a distance *F* (:attr:`~mitnerf.data.dataset.RaySet.free`: the nearest depth over the
pixel and its neighbours, or the whole ray where none of them hits), the weight of every interval that ends
before *F* - *m* is a fill-in or a floater: :math:`\mathcal L_{free} = \sum_{i:\, t_i + \delta_i \le F - m} w_i`,
the mean over the rays that have an *F* (*F* > 0). It says nothing about where the surface is within the
margin *m*, nor about anything behind it.

**Solid behind the surface.** An opaque object's matter goes on behind the surface that the depth measured.
At a point drawn on each pixel-centre ray at :math:`t \in [D + s_0, D + \tau]` (:math:`s_0` the start,
:math:`\tau` the ray's solid extent: the thickness, cut where a training view shows empty space,
:mod:`mitnerf.data.carve`), :math:`\mathcal L_{solid} = (\max(0, 1 - \sigma / \sigma_s))^2` with
:math:`\sigma_s` the density the geometry metrics take for matter (:data:`mitnerf.geometry.mesh.LEVEL`), the
mean over the rays with an extent: the density then encloses a solid rather than a shell with unseen, empty
inside, and a thin part (an ear, a wall) gets no matter out of its back.

**Opacity entropy.** :math:`-(A \log A + (1 - A) \log(1 - A))` per ray, the mean over rays."""

from __future__ import annotations

import math

import drjit as dr
from drjit.auto.ad import Float, UInt32

EPS = 1e-5


def distortion(weights: Float, t: Float, delta: Float, N: int) -> Float:
    """Mean over rays of mip-NeRF 360's distortion loss (``[n_rays * N]`` inputs, sorted per ray)."""
    m = t + 0.5 * delta
    W = dr.block_prefix_sum(weights, N, exclusive=True)
    S = dr.block_prefix_sum(weights * m, N, exclusive=True)
    per_sample = 2.0 * weights * (m * W - S) + (1.0 / 3.0) * dr.square(weights) * delta
    return dr.mean(dr.block_sum(per_sample, N))


def opacity_entropy(opacity: Float) -> Float:
    """Mean binary entropy of the rays' opacities."""
    a = dr.clip(opacity, 1e-4, 1.0 - 1e-4)
    return dr.mean(-(a * dr.log(a) + (1.0 - a) * dr.log(1.0 - a)))


def free_space(weights: Float, t: Float, delta: Float, free: Float, N: int, margin: float) -> Float:
    """Mean over rays with ``free > 0`` of the weight of their intervals that end before ``free - margin``.
    ``weights, t, delta``: ``[n_rays * N]``; ``free``: ``[n_rays]`` (0: unknown, inf: the whole ray)."""
    ray = dr.arange(UInt32, dr.width(t)) // N
    F = dr.gather(Float, free, ray)
    before = (t + delta <= F - margin) & (delta > 0)
    per_ray = dr.block_sum(dr.select(before, weights, 0.0), N)
    known = dr.select(free > 0, 1.0, 0.0)
    return dr.sum(per_ray * known) / dr.maximum(dr.sum(known), 1.0)


def solid_behind(sigma: Float, hit: Float, level: float) -> Float:
    """Mean over the rays with ``hit`` 1 (those with a solid extent) of ``max(0, 1 - sigma / level)^2``;
    ``sigma, hit``: ``[n_rays]``."""
    short = dr.maximum(1.0 - sigma * (1.0 / level), 0.0)
    return dr.sum(short * short * hit) / dr.maximum(dr.sum(hit), 1.0)


def mse(rgb: list, target: list, weight: Float | None = None) -> Float:
    """Mean over rays and channels of the squared residual, each ray's times its ``weight`` ``[n_rays]`` (None: 1)."""
    sq = sum(dr.square(c - t) for c, t in zip(rgb, target))
    return dr.mean(sq if weight is None else sq * weight) * (1.0 / 3.0)


def rms_error(rgb: list, target: list) -> Float:
    """``[n_rays]``: each ray's root mean square colour residual, without gradients (:mod:`.mining`'s error)."""
    return dr.sqrt(sum(dr.square(dr.detach(c) - t) for c, t in zip(rgb, target)) * (1.0 / 3.0))


def depth_kl(weights: Float, t: Float, delta: Float, depth: Float, hit: Float, N: int, sigma: float) -> Float:
    """Mean over hit rays of the KL estimate above. ``weights, t, delta``: ``[n_rays * N]``;
    ``depth`` (ground truth) and ``hit`` (1 for rays with a depth, else 0): ``[n_rays]``."""
    ray = dr.arange(UInt32, dr.width(t)) // N
    D = dr.gather(Float, depth, ray)
    z = (t - D) * (1.0 / sigma)
    log_q = -0.5 * z * z - math.log(sigma * math.sqrt(2.0 * math.pi))
    q = dr.exp(log_q)
    # skip zero-length intervals (a jittered last sample on far, an unused occupancy slot), not log(0 / 0)
    safe = dr.maximum(delta, 1e-12)
    per_sample = dr.select(delta > 0, q * delta * (log_q - dr.log(weights / safe + EPS)), 0.0)
    per_ray = dr.block_sum(per_sample, N) * hit
    return dr.sum(per_ray) / dr.maximum(dr.sum(hit), 1.0)
