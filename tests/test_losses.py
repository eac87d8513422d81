"""The DS-NeRF depth loss: value and gradient by hand, and its torch twin."""

import math

import drjit as dr
import numpy as np
import pytest
import torch
from drjit.auto.ad import Float

from mitnerf.reference.train.losses import depth_kl as depth_kl_torch
from mitnerf.train.losses import EPS, depth_kl


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
    rng = np.random.default_rng(0)
    n, N = 6, 16
    t = np.sort(rng.uniform(1, 5, (n, N)), axis=1).astype(np.float32)
    delta = np.diff(np.c_[t, np.full(n, 5.0)], axis=1).astype(np.float32)
    w = rng.dirichlet(np.ones(N), n).astype(np.float32) * 0.9
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
