r"""The volume integral as a custom differentiable operation, with a replayed adjoint.

For samples :math:`t_0 < \dots < t_{N-1}` on a ray, :math:`\delta_i = t_{i+1} - t_i`,
density :math:`\sigma_i` and colour :math:`c_i` (Max 1995; NeRF):

.. math::

    \alpha_i = 1 - e^{-\sigma_i \delta_i},\quad T_{i+1} = T_i (1 - \alpha_i),\quad w_i = T_i \alpha_i,

    C = \sum_{i:\, w_i > w_{min}} w_i c_i + T_N c_{bg},\qquad D = \sum_i w_i t_i,\qquad A = \sum_i w_i = 1 - T_N.

A sample whose weight is at most :math:`w_{min}` (:data:`W_MIN` unless the render configuration says otherwise;
empty space, or behind an opaque surface) adds no colour, and a field that can skip that work
(``skips_color``: the dense grid) reads only its density there, in the primal and in the adjoint. The colour
left out is at most :math:`N w_{min}` per ray and in practice far less. The adjoint below is the exact gradient
of this model, in which a left-out sample's colour counts as nothing: its density's gradient sees a sample
that adds no colour, not the colour the field holds there (at equal steps the fits are as good:
``benchmarks/grid_step.py``). Every engine (the replay, plain AD, the torch twin) follows the same rule; they
agree up to rounding of weights within float precision of :math:`w_{min}`, and ``w_min = 0`` counts every
sample of positive weight.

**Primal** (:class:`VolumeIntegral`): one symbolic loop marches all rays together, one sample
per ray per step, accumulating ``C, D, A``; nothing per sample is kept (weights only when asked). A ray's march
ends after the last sample its sampler placed (:attr:`~.samplers._Sampler.count`; the slots after it are empty),
and, when rendering without gradients, where its transmittance falls to ``stop`` (:math:`w_{min}`): each later
sample's weight is at most that, so it would add no colour; depth and opacity then differ by at most ``stop``.
The rays are marched in an order grouped by their sample count (:func:`.samplers.by_count`), so the lanes of a SIMD
packet end their loops together; the adjoint replays the same order.

**Adjoint** (radiative backpropagation, as Mitsuba's ``prb`` integrators): with output
gradients :math:`\bar C, \bar D, \bar A` and optionally :math:`\bar w_i`, define the
per-sample scalar :math:`g_i = \langle \bar C, c_i\rangle + \bar D t_i + \bar A + \bar w_i`.
Since :math:`\partial w_k / \partial \sigma_i = \delta_i T_{i+1}` for :math:`k = i` and
:math:`-\delta_i w_k` for :math:`k > i`,

.. math::

    \frac{\partial L}{\partial \sigma_i} = \delta_i \Big(T_{i+1} g_i - R_i\Big),\quad
    R_i = \sum_{k>i} w_k g_k + T_N \langle \bar C, c_{bg}\rangle,\qquad
    \frac{\partial L}{\partial c_i} = w_i \bar C .

:math:`R` starts as :math:`\langle \bar C, C\rangle + \bar D D + \bar A A + \sum_k \bar w_k w_k`
(all known from the primal) and loses :math:`w_i g_i` at each step, so the backward
pass replays the same march once, re-evaluates the field at each sample under
``dr.resume_grad()`` and back-propagates :math:`\sigma_i \partial L/\partial\sigma_i +
\langle c_i, \partial L/\partial c_i\rangle` into the field's parameters. Memory is
O(rays), not O(rays x samples).

The field enters through a *source* ``(params, x, d, sample_index, keep) -> (sigma, rgb)``: a
traceable field called inside the loop, or :func:`gathered_source`, which reads samples that a
non-traceable field (tensor-mode MLP) evaluated beforehand. ``keep(sigma)`` says which samples' colour counts
(:math:`w_i > w_{min}`); a source may return anything elsewhere.
"""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
from drjit.auto.ad import Float, UInt32

from .samplers import by_count, per_sample


def in_lanes(values, order) -> list:
    """Per-ray arrays (or constants) in the march's lane order (``order``: :func:`.samplers.by_count`; None: as
    they are)."""
    return list(values) if order is None else [per_sample(Float(v), order) for v in values]


def in_rays(values, order) -> list:
    """Lane-order arrays (of any type) back in ray order."""
    if order is None:
        return list(values)
    out = [dr.zeros(type(v), dr.width(order)) for v in values]
    for r, v in zip(out, values):
        dr.scatter(r, v, order, mode=dr.ReduceMode.Permute)
    return out


@dataclass
class RenderOutput:
    """Per-ray results of a volume integral."""

    rgb: list
    """Colour, 3 arrays ``[n_rays]`` (composited over the background)."""
    depth: Float
    """Expected termination distance :math:`\\sum_i w_i t_i` ``[n_rays]`` (not divided by opacity)."""
    opacity: Float
    """:math:`A = \\sum_i w_i = 1 - T_N` ``[n_rays]``."""
    weights: Float | None = None
    """:math:`w_i`, ray-major ``[n_rays * N]``, when requested."""


W_MIN = 1e-4
"""The default :math:`w_{min}`: samples of at most this weight add no colour (see the module docstring); the
value of nerfacc's and instant-ngp's early-stop transmittance, far below what an 8-bit image shows."""


def gathered_source(params, x, d, index, keep=None):
    """Read pre-evaluated samples: ``params = {'sigma': [n*N], 'rgb': [n*N*3]}`` (colour only where ``keep``)."""
    sigma = dr.gather(Float, params["sigma"], index, mode=dr.ReduceMode.Permute)
    active = True if keep is None else keep(sigma)
    return sigma, [dr.gather(Float, params["rgb"], index * 3 + k, active, mode=dr.ReduceMode.Permute)
                   for k in range(3)]


def _keep(T: Float, delta: Float, w_min: float):
    """``sigma -> w > w_min`` for the samples at ``T, delta``: the same formula as the weight itself."""
    return lambda sigma: T * (1.0 - dr.exp(-sigma * delta)) > w_min


def marching(sampler, stop: float, ray: UInt32):
    """The loop condition of the march of the lanes' rays ``ray``: samples left (:attr:`~.samplers._Sampler.count`),
    and, with ``stop`` > 0, transmittance above ``stop``."""
    count = None if sampler.count is None else dr.gather(UInt32, sampler.count, ray)
    left = (lambda i: i < sampler.n) if count is None else (lambda i: i < count)
    return (lambda i, T, *_: left(i) & (T > stop)) if stop > 0 else (lambda i, *_: left(i))


def _dot3(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


class VolumeIntegral(dr.CustomOp):
    """``dr.custom(VolumeIntegral, params, origins, directions, near, far, source, sampler,
    background, want_weights, input_grads, w_min)`` -> ``(rgb, depth, opacity, weights)``."""

    def eval(self, params, origins, directions, near, far, source, sampler, background,
             want_weights=False, input_grads=False, w_min=W_MIN, stop=0.0):
        self.args = (params, origins, directions, near, far, source, sampler, input_grads, w_min, stop)
        n, N = dr.width(origins[0]), sampler.n
        self.order = order = by_count(sampler)
        ray = dr.arange(UInt32, n) if order is None else order       # lane -> ray
        o, d = in_lanes(origins, order), in_lanes(directions, order)
        near_r, far_r = per_sample(near, ray), per_sample(far, ray)
        weights = dr.zeros(Float, n * N) if want_weights else None

        def body(i, T, C, D):
            t, delta = sampler.interval(ray, i, near_r, far_r)
            x = [oi + t * di for oi, di in zip(o, d)]
            sigma, rgb = source(params, x, d, ray * N + i, _keep(T, delta, w_min))
            alpha = 1.0 - dr.exp(-sigma * delta)
            w = T * alpha
            rgb = [dr.select(w > w_min, c, 0.0) for c in rgb]
            if want_weights:
                dr.scatter(weights, w, ray * N + i)
            return i + 1, T * (1.0 - alpha), [c + w * ci for c, ci in zip(C, rgb)], D + w * t

        state = (UInt32(0), dr.full(Float, 1.0, n), [dr.zeros(Float, n) for _ in range(3)], dr.zeros(Float, n))
        _, T, C, D = dr.while_loop(state, marching(sampler, stop, ray), body, label="volume_integral")
        C = [c + T * b for c, b in zip(C, in_lanes(background, order))]
        *C, D, A = in_rays([*C, D, 1.0 - T], order)
        self.out = (C, D, A, weights)
        return self.out

    def backward(self):
        params, origins, directions, near, far, source, sampler, input_grads, w_min, stop = self.args
        order = self.order
        dC, dD, dA, dW = self.grad_out()
        C, D, A, W = self.out
        n, N = dr.width(origins[0]), sampler.n
        ray = dr.arange(UInt32, n) if order is None else order
        o, d = in_lanes(origins, order), in_lanes(directions, order)
        (*dC, dD, dA), (*C, D, A) = in_lanes([*dC, dD, dA], order), in_lanes([*C, D, A], order)
        near_r, far_r = per_sample(near, ray), per_sample(far, ray)
        P = {k: dr.detach(v) for k, v in params.items()}    # fresh leaves that collect the adjoint
        dr.enable_grad(P)
        R = _dot3(dC, C) + dD * D + dA * A
        use_dw = W is not None and dW is not None and dr.width(dW) == n * N
        if use_dw:
            R = R + per_sample(dr.block_sum(dW * W, N), ray)

        def body(i, T, R, go, gd):
            t, delta = sampler.interval(ray, i, near_r, far_r)
            with dr.resume_grad():
                x = [oi + t * di for oi, di in zip(o, d)]
                dirs = [Float(di) for di in d] if input_grads else d
                if input_grads:
                    dr.enable_grad(x, dirs)
                sigma, rgb = source(P, x, dirs, ray * N + i, _keep(T, delta, w_min))
                s = dr.detach(sigma)
                alpha = 1.0 - dr.exp(-s * delta)
                w = T * alpha
                rgb = [dr.select(w > w_min, c, 0.0) for c in rgb]
                c = [dr.detach(ci) for ci in rgb]
                T_next = T * (1.0 - alpha)
                g = _dot3(dC, c) + dD * t + dA
                if use_dw:
                    g = g + dr.gather(Float, dW, ray * N + i)
                R = R - w * g
                d_sigma = delta * (T_next * g - R)
                dr.backward_from(sigma * d_sigma + _dot3(rgb, [w * dc for dc in dC]),
                                 flags=dr.ADFlag.Default | dr.ADFlag.AllowNoGrad)
                if input_grads:
                    gx = [dr.grad(xi) for xi in x]
                    go = [a + b for a, b in zip(go, gx)]
                    gd = [a + t * b + dr.grad(di) for a, b, di in zip(gd, gx, dirs)]
            return i + 1, T_next, R, go, gd

        zeros = [dr.zeros(Float, n) for _ in range(2 * len(origins))]
        state = (UInt32(0), dr.full(Float, 1.0, n), R, zeros[:len(origins)], zeros[len(origins):])
        _, _, _, go, gd = dr.while_loop(state, marching(sampler, stop, ray), body, label="volume_integral_adjoint")
        self.set_grad_in("params", {k: dr.grad(v) for k, v in P.items()})
        if input_grads:
            self.set_grad_in("origins", in_rays(go, order))
            self.set_grad_in("directions", in_rays(gd, order))

    def forward(self):
        raise NotImplementedError("VolumeIntegral supports reverse mode only; use method='autodiff' "
                                  "for forward-mode derivatives")

    def name(self):
        return "VolumeIntegral"
