"""Renders with the colour deferred (:mod:`mitnerf.render.deferred`): the fused march's integral, on hand-worked
cases and against the fused march itself."""

import math
from dataclasses import replace

import drjit as dr
import numpy as np
import pytest
from drjit.auto.ad import Float, UInt32

from mitnerf.fields.grid import GridConfig, GridField
from mitnerf.render.occupancy import OccupancyConfig, OccupancyGrid, OccupiedSampler
from mitnerf.render.pipeline import Model, RenderConfig
from mitnerf.render.samplers import Explicit
from mitnerf.render.volume import volume_render
from test_integral import PiecewiseField


class DeferringField(PiecewiseField):
    """The piecewise field of ``test_integral``, declaring that its colour may be skipped: renders defer it."""

    skips_color = True


def rays(n):
    return ([Float(np.zeros(n, np.float32)), Float(np.arange(n, dtype=np.float32) / 100.0)],
            [Float(np.ones(n, np.float32)), Float(np.zeros(n, np.float32))])


def colours(out):
    return np.stack([np.asarray(c) for c in out.rgb], 1)


def test_two_samples_by_hand():
    # test_integral's case, deferred: samples at t = 1, 2, far = 3 (delta 1), sigma = 1, red then green, blue behind
    #   w = [1 - e^-1, e^-1 (1 - e^-1)] = [0.63212, 0.23254]; C = (0.63212, 0.23254, e^-2 = 0.13534)
    #   D = 0.63212 + 2 * 0.23254 = 1.09720; A = 1 - e^-2 = 0.86466
    field = DeferringField([[1.0, 1.0]], [[[1, 0, 0], [0, 1, 0]]], [[1.0, 2.0]])
    o, d = rays(1)
    out = volume_render(field, field.params, o, d, 0.5, 3.0, Explicit(Float([1.0, 2.0]), 2), (0, 0, 1), stop=1e-4)
    a = 1 - math.exp(-1)
    np.testing.assert_allclose(colours(out), [[a, math.exp(-1) * a, math.exp(-2)]], rtol=1e-6)
    np.testing.assert_allclose(np.asarray(out.depth), [a + 2 * math.exp(-1) * a], rtol=1e-6)
    np.testing.assert_allclose(np.asarray(out.opacity), [1 - math.exp(-2)], rtol=1e-6)


def test_the_march_ends_at_stop_and_skips_light_samples():
    # ray 0: sigma = 10 at t = 1, 2, 3 (far 4): T = e^-10 = 4.5e-5 < stop after the first sample, so the march ends:
    #   C = (1 - e^-10) red, A = 1 - e^-10 (not 1 - e^-30)
    # ray 1: sigma = [5e-5, 1, 0]: w0 = 1 - e^-5e-5 = 5.0e-5 <= w_min 1e-4, so its white adds nothing;
    #   w1 = e^-5e-5 (1 - e^-1) = 0.632089: C = w1 red + e^-1.00005 blue, D = w0 + 2 w1
    sigma, t = [[10.0, 10.0, 10.0], [5e-5, 1.0, 0.0]], [[1.0, 2.0, 3.0]] * 2
    rgb = [[[1, 0, 0], [0, 1, 0], [0, 0, 1]], [[1, 1, 1], [1, 0, 0], [0, 1, 0]]]
    field = DeferringField(sigma, rgb, t)
    o, d = rays(2)
    out = volume_render(field, field.params, o, d, 0.5, 4.0, Explicit(Float(np.ravel(t)), 3), (0, 0, 1), stop=1e-4)
    w0, w1 = 1 - math.exp(-5e-5), math.exp(-5e-5) * (1 - math.exp(-1))
    np.testing.assert_allclose(colours(out), [[1 - math.exp(-10), 0, math.exp(-10)],
                                              [w1, 0, math.exp(-1.00005)]], rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(np.asarray(out.opacity), [1 - math.exp(-10), 1 - math.exp(-1.00005)], rtol=1e-6)
    np.testing.assert_allclose(np.asarray(out.depth)[1], w0 + 2 * w1, rtol=1e-6)


def test_rays_that_keep_no_sample_show_the_background():
    # three rays with no samples (count 0), and one whose two samples have sigma = 0 (weights 0): nothing is kept,
    # so every colour is the background, every depth and opacity 0
    field = DeferringField([[0.0, 0.0]] * 4, [[[1, 0, 0], [0, 1, 0]]] * 4, [[1.0, 2.0]] * 4)
    o, d = rays(4)
    sampler = Explicit(Float([1.0, 2.0] * 4), 2, Float([1.0, 1.0] * 4), UInt32([0, 0, 0, 2]))
    out = volume_render(field, field.params, o, d, 0.5, 3.0, sampler, (0.1, 0.2, 0.3), stop=1e-4)
    np.testing.assert_allclose(colours(out), [[0.1, 0.2, 0.3]] * 4, rtol=1e-7)
    assert not np.asarray(out.depth).any() and not np.asarray(out.opacity).any()


def test_packed_samples_reach_their_rays_past_rays_that_keep_none():
    # five rays, samples at t = 1, 2, 3 (far 4, delta 1), background (0.1, 0.2, 0.3):
    #   rays 0, 2 and 4 (first, between, last): sigma 0, nothing kept: C = background
    #   ray 1: sigma [1, 5e-5, 1], red, white, green: w0 = 1 - e^-1 = 0.632121; w1 = e^-1 (1 - e^-5e-5) = 1.8e-5 <=
    #     w_min, skipped; w2 = e^-1.00005 (1 - e^-1) = 0.232534: C = (w0, w2, 0) + e^-2.00005 background
    #   ray 3: sigma [0, 0, 2], blue last: w2 = 1 - e^-2 = 0.864665: C = (0, 0, w2) + e^-2 background
    sigma = [[0.0] * 3, [1.0, 5e-5, 1.0], [0.0] * 3, [0.0, 0.0, 2.0], [0.0] * 3]
    rgb = [[[1, 1, 1]] * 3, [[1, 0, 0], [1, 1, 1], [0, 1, 0]], [[1, 1, 1]] * 3, [[1, 1, 1], [1, 1, 1], [0, 0, 1]],
           [[1, 1, 1]] * 3]
    field = DeferringField(sigma, rgb, [[1.0, 2.0, 3.0]] * 5)
    o, d = rays(5)
    bg = np.array([0.1, 0.2, 0.3])
    out = volume_render(field, field.params, o, d, 0.5, 4.0, Explicit(Float([1.0, 2.0, 3.0] * 5), 3), tuple(bg),
                        stop=1e-4)
    e = math.exp
    expected = [bg, [1 - e(-1), e(-1.00005) * (1 - e(-1)), 0] + e(-2.00005) * bg, bg, [0, 0, 1 - e(-2)] + e(-2) * bg,
                bg]
    np.testing.assert_allclose(colours(out), expected, rtol=1e-5, atol=1e-7)


def test_deferred_equals_the_fused_march_on_uneven_rays():
    # counts [3, 0, 2, 3, 1] in slots whose unused ends hold nonsense (nothing may read them): the march takes the
    # rays grouped by count, and each ray's result is the fused march's (which weights=True keeps), to rounding
    count = np.array([3, 0, 2, 3, 1], np.uint32)
    t = np.array([[1, 1.5, 2], [9, -4, 7], [1, 2, 1e9], [1.2, 1.4, 2.5], [2, -1, 5]], np.float32)
    delta = np.array([[0.5, 0.5, 1], [np.nan, 3, 3], [1, 1, np.nan], [0.2, 1.1, 0.5], [1, np.inf, 4]], np.float32)
    sampler = Explicit(Float(t.ravel()), 3, Float(delta.ravel()), UInt32(count))
    rng = np.random.default_rng(5)
    field = DeferringField(rng.uniform(0, 3, (5, 3)), rng.uniform(0, 1, (5, 3, 3)), np.where(t < 1, 3, t))
    o, d = rays(5)
    deferred, fused = (volume_render(field, field.params, o, d, 0.5, 3.0, sampler, (0.2, 0.3, 0.4), stop=1e-4,
                                     weights=w) for w in (False, True))
    assert deferred.weights is None and fused.weights is not None
    np.testing.assert_allclose(colours(deferred)[1], [0.2, 0.3, 0.4])          # no samples: the background
    for a, b in ((deferred.depth, fused.depth), (deferred.opacity, fused.opacity)):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(colours(deferred), colours(fused), rtol=1e-6, atol=1e-7)


def test_a_grid_rendered_through_its_occupancy_grid_as_by_the_fused_march():
    """A 3D grid of random values with view harmonics, rendered through an occupancy grid of its density: the model's
    render (deferred colour, the sampler's unused slots unwritten) equals the fused march's (asked for weights, or
    with ``defer_color=False``), and the samples the sampler reports are those of a sampler that writes every slot."""
    cfg = GridConfig(dim=3, resolution=9, view_dependent=True, density_refine=2, density_scale=1.0, bound=1.0)
    field = GridField(cfg)
    rng = np.random.default_rng(7)
    params = field.from_numpy({k: rng.normal(0, 1.5, v.shape).astype(np.float32)
                               for k, v in field.init_numpy(0).items()})
    occ = OccupancyConfig(enabled=True, resolution=8, warmup=0, march_bins=48, threshold=0.5)
    grid = OccupancyGrid(occ, 3, bound=1.0)
    grid.update(lambda x: field.density(params, x), step=0, seed=1)
    model = Model({"coarse": field}, RenderConfig(n_coarse=8, occupancy=occ, background="white", render_oversample=2))
    n = 300
    o = rng.normal(size=(n, 3)).astype(np.float32)
    o = 3.0 * o / np.linalg.norm(o, axis=1, keepdims=True)
    d = -o / 3.0 + rng.normal(0, 0.15, (n, 3)).astype(np.float32)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o, d = [Float(o[:, a]) for a in range(3)], [Float(d[:, a]) for a in range(3)]
    fused_model = Model({"coarse": field}, replace(model.render_cfg, defer_color=False))
    with dr.suspend_grad():
        out = [m.render({f"coarse.{k}": v for k, v in params.items()}, o, d, 1.5, 4.5, UInt32(0), training=False,
                        weights=w, occupancy=grid.lookup)
               for m, w in ((model, False), (model, True), (fused_model, False))]
        filled, unfilled = (OccupiedSampler(*grid.lookup, 16, 48, 1.0, 8, UInt32(0), jitter=False, fill=f)
                            .build(o, d, 1.5, 4.5) for f in (True, False))
    deferred, fused = out[0]["coarse"], out[1]["coarse"]
    assert 0.05 < np.mean(np.asarray(fused.opacity)) < 0.95       # rays that see something and rays that do not
    for a, b in zip([*out[1]["coarse"].rgb, fused.depth], [*out[2]["coarse"].rgb, out[2]["coarse"].depth]):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))         # defer_color=False: the fused march
    np.testing.assert_allclose(colours(deferred), colours(fused), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(np.asarray(deferred.depth), np.asarray(fused.depth), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(np.asarray(deferred.opacity), np.asarray(fused.opacity), rtol=1e-5, atol=1e-6)
    for a, b in zip(filled.points(n, Float(1.5), Float(4.5)), unfilled.points(n, Float(1.5), Float(4.5))):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_a_render_of_more_slots_than_the_cap_marches_fused(monkeypatch):
    """Past ``DEFER_MAX_SLOTS`` (rays x samples) a render takes the fused march, which holds nothing per slot: the
    same colour (the two-sample case above, 2 slots against a cap of 1), and the deferred path is not entered."""
    import mitnerf.render.volume as volume

    field = DeferringField([[1.0, 1.0]], [[[1, 0, 0], [0, 1, 0]]], [[1.0, 2.0]])
    o, d = rays(1)
    deferred = volume.volume_render(field, field.params, o, d, 0.5, 3.0, Explicit(Float([1.0, 2.0]), 2), (0, 0, 1),
                                    stop=1e-4)
    monkeypatch.setattr(volume, "DEFER_MAX_SLOTS", 1)
    monkeypatch.setattr(volume, "render_deferred", lambda *a, **k: pytest.fail("deferred past the cap"))
    fused = volume.volume_render(field, field.params, o, d, 0.5, 3.0, Explicit(Float([1.0, 2.0]), 2), (0, 0, 1),
                                 stop=1e-4)
    np.testing.assert_allclose(colours(fused), colours(deferred), rtol=1e-6)
