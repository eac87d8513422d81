"""Samplers: stratified positions, importance sampling, and their torch twins."""

import numpy as np
import torch
from drjit.auto.ad import Float, UInt32

from mitnerf.reference.render import samplers as tw
from mitnerf.render.samplers import Stratified, importance_sample


def test_stratified_without_jitter_is_the_bin_centres():
    # near 2, far 6, 4 samples: bins of width 1 -> centres 2.5, 3.5, 4.5, 5.5; the last interval
    # closes at far, so delta = 1, 1, 1, 0.5
    t, delta = Stratified(4, UInt32(0), jitter=False).points(1, Float(2.0), Float(6.0))
    np.testing.assert_allclose(np.asarray(t), [2.5, 3.5, 4.5, 5.5])
    np.testing.assert_allclose(np.asarray(delta), [1.0, 1.0, 1.0, 0.5])


def test_jitter_stays_in_its_bin_and_matches_the_twin():
    n, rays = 16, 300
    t, _ = Stratified(n, UInt32(42)).points(rays, Float(1.0), Float(5.0))
    t = np.asarray(t).reshape(rays, n)
    lo = 1.0 + 4.0 * np.arange(n) / n
    assert ((t >= lo) & (t < lo + 4.0 / n)).all()
    assert t.std(axis=0).min() > 0.05                  # actually jittered
    tt, _ = tw.Stratified(n, 42).points(rays, 1.0, 5.0)
    np.testing.assert_array_equal(tt.numpy(), t)       # the same hash, bit for bit


def test_importance_sampling_concentrates_and_merges():
    rays, nc, nf = 64, 8, 16
    t, delta = Stratified(nc, UInt32(3), jitter=False).points(rays, Float(0.0), Float(8.0))
    w = np.full((rays, nc), 1e-6, np.float32)
    w[:, 5] = 1.0                                       # all weight in the bin [5, 6)
    fine = importance_sample(t, delta, Float(w.ravel()), rays, nc, nf, UInt32(9), True)
    merged = np.asarray(fine.t_flat).reshape(rays, nc + nf)
    assert (np.diff(merged, axis=1) >= 0).all()          # sorted per ray
    coarse = np.asarray(t).reshape(rays, nc)
    new = np.array([np.setdiff1d(m, c) for m, c in zip(merged, coarse)])
    assert ((new >= 5.5) & (new <= 6.5)).mean() > 0.95   # the coarse bin [5.5, 6.5) around t = 5.5
    tt, ttn = tw.Stratified(nc, 3, jitter=False).points(rays, 0.0, 8.0)
    twin = tw.importance_sample(tt, ttn, torch.from_numpy(w), nf, 9, True)
    np.testing.assert_allclose(twin.t.numpy(), merged, atol=2e-6)
