"""The depth losses (DS-NeRF, free space, solid behind the surface): values and gradients by hand, and their torch twins."""

import math

import drjit as dr
import numpy as np
import pytest
import torch
from drjit.auto.ad import Float

from mitnerf.reference.train.losses import depth_kl as depth_kl_torch
from mitnerf.train.losses import EPS, depth_kl


def random_samples(rng, n: int, N: int):
    """Sorted sample distances in [1, 5) ``t``, their intervals ``delta`` up to 5 and weights ``w`` summing to 0.9
    per ray: ``[n, N]`` each."""
    t = np.sort(rng.uniform(1, 5, (n, N)), axis=1).astype(np.float32)
    delta = np.diff(np.c_[t, np.full(n, 5.0)], axis=1).astype(np.float32)
    return t, delta, rng.dirichlet(np.ones(N), n).astype(np.float32) * 0.9


def test_depth_kl_by_hand():
    # one ray, samples at t = 1, 2 with delta = 1, weights w = (0.6, 0.3); depth D = 1, sigma = 1:
    #   q(1) = 1/sqrt(2 pi) = 0.398942, log q(1) = -0.918939
    #   q(2) = e^-0.5/sqrt(2 pi) = 0.241971, log q(2) = -1.418939
    #   L = 0.398942 (-0.918939 - log 0.60001) + 0.241971 (-1.418939 - log 0.30001) = -0.214843
    #   dL/dw_i = -q_i / (w_i / delta_i + eps) = (-0.664893, -0.806544)
    w = Float(0.6, 0.3)
    dr.enable_grad(w)
    loss = depth_kl(w, Float(1.0, 2.0), Float(1.0, 1.0), Float(1.0), Float(1.0), 2, 1.0)
    dr.backward(loss)
    q = np.array([1.0, math.exp(-0.5)]) / math.sqrt(2 * math.pi)
    expected = float(np.sum(q * (np.log(q) - np.log(np.array([0.6, 0.3]) + EPS))))
    assert expected == pytest.approx(-0.214843, abs=1e-5)
    assert float(loss[0]) == pytest.approx(expected, rel=1e-5)
    np.testing.assert_allclose(np.asarray(dr.grad(w)), -q / (np.array([0.6, 0.3]) + EPS), rtol=1e-5)


def test_rays_without_depth_do_not_count_and_the_twin_agrees():
    rng, n, N = np.random.default_rng(0), 6, 16
    t, delta, w = random_samples(rng, n, N)
    depth = rng.uniform(2, 4, n).astype(np.float32)
    hit = np.array([1, 1, 0, 1, 0, 1], np.float32)
    W = Float(w.ravel())
    dr.enable_grad(W)
    loss = depth_kl(W, Float(t.ravel()), Float(delta.ravel()), Float(depth), Float(hit), N, 0.3)
    dr.backward(loss)
    tw = torch.tensor(w, requires_grad=True)
    tl = depth_kl_torch(tw, torch.from_numpy(t), torch.from_numpy(delta), torch.from_numpy(depth),
                        torch.from_numpy(hit), N, 0.3)
    tl.backward()
    assert float(loss[0]) == pytest.approx(float(tl.detach()), rel=1e-5)
    g = np.asarray(dr.grad(W)).reshape(n, N)
    np.testing.assert_allclose(g, tw.grad.numpy(), rtol=1e-5, atol=1e-7)
    assert not g[hit == 0].any()            # misses carry no depth, so no gradient


def test_zero_length_intervals_are_skipped():
    # the second interval has length 0 (a jittered sample that rounded onto far): without the
    # guard the loss would be log(0 / 0) = NaN; with it, that sample stands for nothing
    w = Float(0.6, 0.0)
    dr.enable_grad(w)
    loss = depth_kl(w, Float(1.0, 2.0), Float(1.0, 0.0), Float(1.0), Float(1.0), 2, 1.0)
    dr.backward(loss)
    q0 = 1.0 / math.sqrt(2 * math.pi)
    assert float(loss[0]) == pytest.approx(q0 * (math.log(q0) - math.log(0.6 + EPS)), rel=1e-5)
    assert np.isfinite(np.asarray(dr.grad(w))).all()


# ----------------------------------------------------------------------------- free space
def test_free_space_by_hand():
    # two rays of 3 samples at t = 1, 2, 3 (delta = 1), free margin 0.5:
    #   ray 0: free F = 3.6, so the intervals ending at 2 and 3 (<= 3.1) count: 0.1 + 0.2 = 0.3
    #   ray 1: F = inf (its pixel and neighbours miss): all three count: 0.05 + 0.05 + 0.1 = 0.2
    #   mean over the two rays: 0.25; dL/dw = 1/2 on counted samples, 0 on ray 0's last
    from mitnerf.train.losses import free_space
    w = Float(0.1, 0.2, 0.6, 0.05, 0.05, 0.1)
    dr.enable_grad(w)
    loss = free_space(w, Float(1, 2, 3, 1, 2, 3), Float(1, 1, 1, 1, 1, 1), Float(3.6, float("inf")), 3, 0.5)
    dr.backward(loss)
    assert float(loss[0]) == pytest.approx(0.25, rel=1e-6)
    np.testing.assert_allclose(np.asarray(dr.grad(w)), [0.5, 0.5, 0, 0.5, 0.5, 0.5])


def test_free_space_skips_unknown_rays_and_the_twin_agrees():
    from mitnerf.reference.train.losses import free_space as free_space_torch
    from mitnerf.train.losses import free_space
    rng, n, N = np.random.default_rng(1), 6, 16
    t, delta, w = random_samples(rng, n, N)
    free = np.array([2.5, 0.0, np.inf, 3.0, 0.0, 4.2], np.float32)     # 0: unknown
    W = Float(w.ravel())
    dr.enable_grad(W)
    loss = free_space(W, Float(t.ravel()), Float(delta.ravel()), Float(free), N, 0.05)
    dr.backward(loss)
    tw = torch.tensor(w, requires_grad=True)
    tl = free_space_torch(tw, torch.from_numpy(t), torch.from_numpy(delta), torch.from_numpy(free), N, 0.05)
    tl.backward()
    assert float(loss[0]) == pytest.approx(float(tl.detach()), rel=1e-5)
    g = np.asarray(dr.grad(W)).reshape(n, N)
    np.testing.assert_allclose(g, tw.grad.numpy(), rtol=1e-6)
    assert not g[free == 0].any()           # nothing known about these rays
    assert g[2].all()                       # inf: every interval of the ray is empty


def test_free_distance_of_a_view():
    from mitnerf.data.dataset import free_distance
    # one 1D view of 6 pixels: depth inf (miss), 2, 1.5, miss, miss, miss -> the least depth of each pixel and
    # its two neighbours: 2, 1.5, 1.5, 1.5, inf, inf (a jittered ray of pixel 3 may reach pixel 2's surface)
    d = np.array([np.inf, 2.0, 1.5, np.inf, np.inf, np.inf]).reshape(1, 6, 1)
    np.testing.assert_array_equal(free_distance(d, None, np.ones((1, 6, 1))).ravel(), [2, 1.5, 1.5, 1.5, np.inf, np.inf])
    # no depth: alpha 0 in the whole neighbourhood means empty all along, anything else unknown (0)
    a = np.array([0, 0, 0, 0.5, 0, 0]).reshape(1, 6, 1)
    np.testing.assert_array_equal(free_distance(None, None, a).ravel(), [np.inf, np.inf, 0, 0, 0, np.inf])
    # a format without alpha (all ones) says nothing
    assert not free_distance(None, None, np.ones((1, 6, 1))).any()
    # 2D images take the 3 x 3 neighbourhood
    img = np.full((1, 3, 3), np.inf)
    img[0, 0, 0] = 1.0
    np.testing.assert_array_equal(free_distance(img, None, np.ones((1, 3, 3)))[0],
                                  [[1, 1, np.inf], [1, 1, np.inf], [np.inf] * 3])


# ----------------------------------------------------------------------------- solid behind the surface
def test_solid_behind_by_hand():
    # three rays, level 3: densities 1.5 (hit), 6 (hit), 0 (a miss, left out):
    #   (1 - 1.5/3)^2 = 0.25, (1 - 6/3) < 0 -> 0; mean over the two hit rays: 0.125
    #   dL/dsigma_0 = 2 (1 - 0.5) (-1/3) / 2 = -1/6; 0 for the dense and the missing ray
    from mitnerf.train.losses import solid_behind
    s = Float(1.5, 6.0, 0.0)
    dr.enable_grad(s)
    loss = solid_behind(s, Float(1.0, 1.0, 0.0), 3.0)
    dr.backward(loss)
    assert float(loss[0]) == pytest.approx(0.125, rel=1e-6)
    np.testing.assert_allclose(np.asarray(dr.grad(s)), [-1 / 6, 0, 0], rtol=1e-6)


def test_solid_points_lie_within_each_rays_extent():
    # depth 2, start 0.005: extent 0.15 -> [2.005, 2.15] (u = 0, 0.5: 2.005, 2.0775); an extent shorter than the
    # start (0.002) -> its end, 2.002, whatever u; no extent -> the surface itself (the loss leaves that ray out)
    from mitnerf.train.backend import behind_depth
    u = np.array([0.0, 0.5, 0.9, 0.3])
    depth, extent = np.full(4, 2.0), np.array([0.15, 0.15, 0.002, 0.0])
    expected = [2.005, 2.0775, 2.002, 2.0]
    np.testing.assert_allclose(behind_depth(u, depth, extent, 0.005), expected, rtol=1e-12)
    got = behind_depth(Float(u), Float(depth), Float(extent), 0.005)
    np.testing.assert_allclose(np.asarray(got), expected, rtol=1e-6)
    np.testing.assert_allclose(behind_depth(torch.tensor(u), torch.tensor(depth), torch.tensor(extent), 0.005).numpy(),
                               expected, rtol=1e-12)


def test_solid_behind_twin_agrees():
    from mitnerf.reference.train.losses import solid_behind as solid_behind_torch
    from mitnerf.train.losses import solid_behind
    rng = np.random.default_rng(2)
    sigma = rng.uniform(0, 8, 12).astype(np.float32)
    hit = (rng.uniform(size=12) < 0.6).astype(np.float32)
    S = Float(sigma)
    dr.enable_grad(S)
    loss = solid_behind(S, Float(hit), 3.0)
    dr.backward(loss)
    ts = torch.tensor(sigma, requires_grad=True)
    tl = solid_behind_torch(ts, torch.from_numpy(hit), 3.0)
    tl.backward()
    assert float(loss[0]) == pytest.approx(float(tl.detach()), rel=1e-6)
    np.testing.assert_allclose(np.asarray(dr.grad(S)), ts.grad.numpy(), rtol=1e-6, atol=1e-8)
