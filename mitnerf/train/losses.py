r"""Losses (Dr.Jit; twin: ``mitnerf.reference.train.losses``).

**Depth supervision (DS-NeRF, Deng et al. 2022).** The ray-termination distribution
of the weights, :math:`h(t) \approx w_i / \delta_i` on sample interval *i*, is pulled
towards :math:`q = \mathcal N(D, \hat\sigma^2)` around the measured depth *D* by
minimising :math:`\mathrm{KL}(q \,\|\, h)`:

.. math::

    \mathcal L_{depth} = \sum_i q(t_i)\, \delta_i \,\big[\log q(t_i) - \log(w_i / \delta_i + \epsilon)\big].

Only :math:`-\sum_i q(t_i) \delta_i \log(w_i/\delta_i + \epsilon)` depends on the weights:
it is the form the original NeRF2D code used (:math:`-\sum \log w \cdot \text{Gaussian}
\cdot \Delta t`, with an unnormalised Gaussian). Keeping :math:`\log q` and
:math:`\log\delta` makes the value a real KL estimate (about 0 when the weights
match the Gaussian, whatever the sampling), so it can be reported and compared;
the gradient is the same. The normalised Gaussian makes :math:`\lambda` independent
of :math:`\hat\sigma`. Rays that miss the object carry no depth and are left out.

**Distortion (mip-NeRF 360, Barron et al. 2022).** With interval midpoints
:math:`m_i = t_i + \delta_i / 2`, :math:`\mathcal L_{dist} = \sum_{i,j} w_i w_j |m_i - m_j|
+ \tfrac13 \sum_i w_i^2 \delta_i`: it pulls each ray's weights into one short interval,
removing floaters and semi-transparent fill. For sorted samples the double sum is
:math:`2 \sum_i w_i (m_i W_{<i} - S_{<i})` with prefix sums :math:`W_{<i} = \sum_{j<i} w_j`,
:math:`S_{<i} = \sum_{j<i} w_j m_j`, so it costs O(N) per ray.

**Opacity entropy.** :math:`-\big(A \log A + (1 - A) \log(1 - A)\big)` per ray, the mean
over rays: a ray should end on the object or see the background, not a haze.
"""

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


def mse(rgb: list, target: list) -> Float:
    return sum(dr.mean(dr.square(c - t)) for c, t in zip(rgb, target)) * (1.0 / 3.0)


def depth_kl(weights: Float, t: Float, delta: Float, depth: Float, hit: Float, N: int, sigma: float) -> Float:
    """Mean over hit rays of the KL estimate above. ``weights, t, delta``: ``[n_rays * N]``;
    ``depth`` (ground truth) and ``hit`` (1 for rays with a depth, else 0): ``[n_rays]``."""
    ray = dr.arange(UInt32, dr.width(t)) // N
    D = dr.gather(Float, depth, ray)
    z = (t - D) * (1.0 / sigma)
    log_q = -0.5 * z * z - math.log(sigma * math.sqrt(2.0 * math.pi))
    q = dr.exp(log_q)
    # a zero-length interval (a jittered last sample rounding onto far, an unused occupancy
    # slot) stands for nothing: skip it rather than take log(0 / 0)
    safe = dr.maximum(delta, 1e-12)
    per_sample = dr.select(delta > 0, q * delta * (log_q - dr.log(weights / safe + EPS)), 0.0)
    per_ray = dr.block_sum(per_sample, N) * hit
    return dr.sum(per_ray) / dr.maximum(dr.sum(hit), 1.0)
