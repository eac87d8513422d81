"""The volume integral on hand-worked cases (both the custom op and plain AD)."""

import math

import drjit as dr
import numpy as np
import pytest
from drjit.auto.ad import Float, UInt32

from mitnerf.fields.base import Field
from mitnerf.render.samplers import Explicit
from mitnerf.render.volume import volume_render


class PiecewiseField(Field):
    """Density and colour given per sample slot: sample i of ray r reads ``sigma[r, i]``.

    Rays start at x = 0 along +x at height y = r / 100; the slot of a point is the
    number of the ray's sample distances t at or below x, minus one."""

    dim, traceable = 2, True
    init_numpy = from_numpy = to_numpy = None       # storage is given, never converted

    def density(self, params, x):
        return self.query(params, x, None)[0]

    def __init__(self, sigma, rgb, t):
        self.t = Float(np.asarray(t, np.float32).ravel())
        self.n = np.shape(t)[-1]
        self.params = {"sigma": Float(np.asarray(sigma, np.float32).ravel()),
                       "rgb": Float(np.asarray(rgb, np.float32).ravel())}

    def query(self, params, x, d, keep=None):      # ignores keep: every colour is real
        ray = UInt32(dr.round(x[1] * 100.0))
        i = UInt32(0)
        for j in range(1, self.n):
            i += dr.select(dr.gather(Float, self.t, ray * self.n + j) <= x[0] + 1e-5, 1, 0)
        k = ray * self.n + i
        sigma = dr.gather(Float, params["sigma"], k)
        return sigma, [dr.gather(Float, params["rgb"], 3 * k + j) for j in range(3)]


def render(sigma, rgb, t, far, bg, method):
    n_rays, n = np.shape(sigma)
    field = PiecewiseField(sigma, rgb, t)
    o = [Float(np.zeros(n_rays, np.float32)), Float(np.arange(n_rays, dtype=np.float32) / 100.0)]
    d = [Float(np.ones(n_rays, np.float32)), Float(np.zeros(n_rays, np.float32))]
    sampler = Explicit(Float(np.asarray(t, np.float32).ravel()), n)
    out = volume_render(field, field.params, o, d, 0.5, far, sampler, bg, method=method, weights=True)
    return (np.stack([np.asarray(c) for c in out.rgb], 1), np.asarray(out.depth), np.asarray(out.opacity),
            np.asarray(out.weights).reshape(n_rays, n))


@pytest.mark.parametrize("method", ["replay", "autodiff"])
def test_two_samples_by_hand(method):
    # one ray, samples at t = 1, 2 and far = 3, so delta = [1, 1]; sigma = 1 at both:
    #   alpha = 1 - e^-1 = 0.63212;  T = [1, e^-1 = 0.36788];  w = [0.63212, 0.23254]
    #   T_end = e^-2 = 0.13534;  colours red, green; background blue
    #   C = (0.63212, 0.23254, 0.13534);  D = 1 * 0.63212 + 2 * 0.23254 = 1.09720;  A = 0.86466
    rgb, depth, opacity, w = render([[1.0, 1.0]], [[[1, 0, 0], [0, 1, 0]]], [[1.0, 2.0]], 3.0, (0, 0, 1), method)
    a = 1 - math.exp(-1)
    np.testing.assert_allclose(w, [[a, math.exp(-1) * a]], rtol=1e-6)
    np.testing.assert_allclose(rgb, [[a, math.exp(-1) * a, math.exp(-2)]], rtol=1e-6)
    np.testing.assert_allclose(depth, [a + 2 * math.exp(-1) * a], rtol=1e-6)
    np.testing.assert_allclose(opacity, [1 - math.exp(-2)], rtol=1e-6)


@pytest.mark.parametrize("method", ["replay", "autodiff"])
def test_empty_opaque_and_uneven_rays(method):
    # ray 0: empty -> the background, depth 0, opacity 0
    # ray 1: sigma = 1e4 at the first sample (delta 0.5) -> all weight there: C = c0, D = t0 = 1
    # ray 2: sigma = [0, 2, 0] with t = [1, 1.25, 2], far 3: only the middle interval (delta 0.75) counts:
    #        w = [0, 1 - e^-1.5 = 0.77687, 0], C = 0.77687 * c1 + e^-1.5 * bg, D = 1.25 * 0.77687
    sigma = [[0, 0, 0], [1e4, 1, 1], [0, 2, 0]]
    rgb = [[[1, 1, 1]] * 3, [[0.2, 0.4, 0.6], [1, 0, 0], [1, 0, 0]], [[1, 0, 0], [0, 0.5, 1], [1, 0, 0]]]
    t = [[1, 2, 2.5], [1, 1.5, 2], [1, 1.25, 2]]
    bg = (0.1, 0.2, 0.3)
    col, depth, opacity, w = render(sigma, rgb, t, 3.0, bg, method)
    np.testing.assert_allclose(col[0], bg, atol=1e-7)
    assert depth[0] == 0 and opacity[0] == 0 and not w[0].any()
    np.testing.assert_allclose(col[1], [0.2, 0.4, 0.6], atol=1e-6)
    np.testing.assert_allclose([depth[1], opacity[1]], [1.0, 1.0], atol=1e-6)
    np.testing.assert_allclose(w[1], [1, 0, 0], atol=1e-6)
    a = 1 - math.exp(-1.5)
    np.testing.assert_allclose(w[2], [0, a, 0], rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(col[2], a * np.array([0, 0.5, 1]) + math.exp(-1.5) * np.array(bg), rtol=1e-6)
    np.testing.assert_allclose(depth[2], 1.25 * a, rtol=1e-6)


def test_custom_op_gradient_matches_the_hand_derivation():
    # one sample, delta = 2, sigma = 0.5, colour c, background b: C = (1 - e^-1) c + e^-1 b
    # dC/dsigma = delta e^(-sigma delta) (c - b) = 2 e^-1 (c - b); dC/dc = 1 - e^-1
    field = PiecewiseField([[0.5]], [[[0.9, 0.5, 0.1]]], [[1.0]])
    dr.enable_grad(field.params)
    o, d = [Float(0.0), Float(0.0)], [Float(1.0), Float(0.0)]
    out = volume_render(field, field.params, o, d, 0.5, 3.0, Explicit(Float(1.0), 1), (0.1, 0.1, 0.1))
    dr.backward(out.rgb[0])            # cotangent (1, 0, 0)
    g_sigma = float(dr.grad(field.params["sigma"])[0])
    g_rgb = np.asarray(dr.grad(field.params["rgb"]))
    assert g_sigma == pytest.approx(2 * math.exp(-1) * (0.9 - 0.1), rel=1e-6)
    np.testing.assert_allclose(g_rgb, [1 - math.exp(-1), 0, 0], rtol=1e-6)


class SkippingField(PiecewiseField):
    """PiecewiseField that honours ``keep``: its colour is NaN wherever it was told the colour is not used."""

    skips_color = True

    def query(self, params, x, d, keep=None):
        sigma, rgb = super().query(params, x, d)
        if keep is None:                # plain AD evaluates every sample
            return sigma, rgb
        kept = keep(sigma)
        return sigma, [dr.select(kept, c, dr.nan) for c in rgb]


@pytest.mark.parametrize("method", ["replay", "autodiff"])
@pytest.mark.parametrize("skipping", [False, True])
def test_a_sample_below_w_min_adds_no_colour(method, skipping):
    # samples at t = 1, 2, far = 3 (delta 1); sigma = [5e-5, 1]: w0 = 1 - e^-5e-5 = 5.0e-5 <= W_MIN = 1e-4,
    # so the white first sample adds no colour; w1 = e^-5e-5 (1 - e^-1) = 0.632089
    #   C = w1 * red + e^-1.00005 * blue = (0.632089, 0, 0.367861);  D = w0 * 1 + w1 * 2 = 1.264228 (all weights)
    cls = SkippingField if skipping else PiecewiseField
    field = cls([[5e-5, 1.0]], [[[1, 1, 1], [1, 0, 0]]], [[1.0, 2.0]])
    dr.enable_grad(field.params)
    o, d = [Float(0.0), Float(0.0)], [Float(1.0), Float(0.0)]
    out = volume_render(field, field.params, o, d, 0.5, 3.0, Explicit(Float([1.0, 2.0]), 2), (0, 0, 1), method=method)
    w0, w1 = 1 - math.exp(-5e-5), math.exp(-5e-5) * (1 - math.exp(-1))
    np.testing.assert_allclose([float(c[0]) for c in out.rgb], [w1, 0, math.exp(-1.00005)], rtol=1e-5, atol=1e-7)
    assert float(out.depth[0]) == pytest.approx(w0 + 2 * w1, rel=1e-6)
    dr.backward(out.rgb[0] + out.rgb[1])            # cotangent (1, 1, 0)
    g_rgb = np.asarray(dr.grad(field.params["rgb"]))
    np.testing.assert_allclose(g_rgb, [0, 0, 0, w1, w1, 0], rtol=1e-5, atol=0)     # no gradient to the skipped colour
    # dC_r/dsigma0 = -delta * w1 (the first sample's colour counts as nothing); dC_r/dsigma1 = delta * e^-1.00005
    g_sigma = np.asarray(dr.grad(field.params["sigma"]))
    np.testing.assert_allclose(g_sigma, [-w1, math.exp(-1.00005)], rtol=1e-4)


def test_the_torch_twin_leaves_out_the_same_colour():
    # the case above, in the torch twin: C = (w1, 0, e^-1.00005)
    torch = pytest.importorskip("torch")
    from mitnerf.reference.render.volume import integrate

    sigma = torch.tensor([[5e-5, 1.0]], requires_grad=True)
    rgb = torch.tensor([[[1.0, 1, 1], [1, 0, 0]]], requires_grad=True)
    out = integrate(sigma, rgb, torch.tensor([[1.0, 2.0]]), torch.tensor([[1.0, 1.0]]), (0, 0, 1))
    w1 = math.exp(-5e-5) * (1 - math.exp(-1))
    np.testing.assert_allclose(out.rgb.detach().numpy()[0], [w1, 0, math.exp(-1.00005)], rtol=1e-5, atol=1e-7)
    (out.rgb[0, 0] + out.rgb[0, 1]).backward()          # the gradients of the Dr.Jit test above
    np.testing.assert_allclose(rgb.grad.numpy().ravel(), [0, 0, 0, w1, w1, 0], rtol=1e-5, atol=0)
    np.testing.assert_allclose(sigma.grad.numpy().ravel(), [-w1, math.exp(-1.00005)], rtol=1e-4)


@pytest.mark.parametrize("method", ["replay", "autodiff"])
def test_w_min_zero_counts_every_colour(method):
    # the case above with w_min = 0: the white first sample now adds w0 = 5.0e-5 to every channel
    field = PiecewiseField([[5e-5, 1.0]], [[[1, 1, 1], [1, 0, 0]]], [[1.0, 2.0]])
    o, d = [Float(0.0), Float(0.0)], [Float(1.0), Float(0.0)]
    out = volume_render(field, field.params, o, d, 0.5, 3.0, Explicit(Float([1.0, 2.0]), 2), (0, 0, 1),
                        method=method, w_min=0.0)
    w0, w1 = 1 - math.exp(-5e-5), math.exp(-5e-5) * (1 - math.exp(-1))
    np.testing.assert_allclose([float(c[0]) for c in out.rgb], [w0 + w1, w0, w0 + math.exp(-1.00005)],
                               rtol=1e-5, atol=1e-7)


def test_a_march_ends_where_transmittance_falls_to_stop():
    # one ray, samples at t = 1, 2, 3 (far 4, delta 1), sigma = 10, 10, 10, colours red, green, blue, background
    # black. w = [1 - e^-10, e^-10 (1 - e^-10), e^-20 (1 - e^-10)] = [0.99995, 4.5e-5, 2.1e-9]: after the first
    # sample T = e^-10 = 4.5e-5 < stop 1e-4 and the march ends; the colour is the same (the later weights are
    # below w_min = 1e-4 and add none either way), the opacity 1 - 4.5e-5 instead of 1 - 9.4e-14.
    sigma, rgb, t = [[10.0, 10.0, 10.0]], [[[1, 0, 0], [0, 1, 0], [0, 0, 1]]], [[1.0, 2.0, 3.0]]
    field = PiecewiseField(sigma, rgb, t)
    o, d = [Float([0.0]), Float([0.0])], [Float([1.0]), Float([0.0])]
    out = [volume_render(field, field.params, o, d, 0.5, 4.0, Explicit(Float([1.0, 2.0, 3.0]), 3), (0, 0, 0),
                         stop=stop) for stop in (0.0, 1e-4)]
    np.testing.assert_array_equal([np.asarray(c) for c in out[0].rgb], [np.asarray(c) for c in out[1].rgb])
    assert np.asarray(out[1].rgb[0])[0] == pytest.approx(1 - math.exp(-10), rel=1e-6)
    assert np.asarray(out[1].opacity)[0] == pytest.approx(1 - math.exp(-10), rel=1e-6)
    assert np.asarray(out[0].opacity)[0] == pytest.approx(1.0, abs=1e-6)


def test_rays_marched_grouped_by_count_give_each_ray_its_own_result():
    # counts [3, 0, 2, 3, 1]: the march takes the rays in the order of their counts, 0, 1, 2, 3, 3
    # (by_count's permutation), and each ray's colour, depth, opacity and gradients are those of plain AD
    # over the same samples (an unused slot has delta 0 and adds nothing)
    count = np.array([3, 0, 2, 3, 1], np.uint32)
    t = np.array([[1, 1.5, 2], [3, 3, 3], [1, 2, 3], [1.2, 1.4, 2.5], [2, 3, 3]], np.float32)
    delta = np.array([[0.5, 0.5, 1], [0, 0, 0], [1, 1, 0], [0.2, 1.1, 0.5], [1, 0, 0]], np.float32)
    sampler = Explicit(Float(t.ravel()), 3, Float(delta.ravel()), UInt32(count))
    from mitnerf.render.samplers import by_count
    order = np.asarray(by_count(sampler))
    assert sorted(order) == [0, 1, 2, 3, 4] and count[order].tolist() == [0, 1, 2, 3, 3]
    rng = np.random.default_rng(3)
    sigma, rgb = rng.uniform(0, 3, (5, 3)), rng.uniform(0, 1, (5, 3, 3))
    cot = [Float(rng.normal(size=5).astype(np.float32)) for _ in range(5)]
    o = [Float(np.zeros(5, np.float32)), Float(np.arange(5, dtype=np.float32) / 100.0)]
    d = [Float(np.ones(5, np.float32)), Float(np.zeros(5, np.float32))]
    results = []
    for method in ("replay", "autodiff"):
        field = PiecewiseField(sigma, rgb, t)
        dr.enable_grad(field.params)
        out = volume_render(field, field.params, o, d, 0.5, 3.0, sampler, (0.2, 0.3, 0.4), method=method)
        dr.backward(sum(c * g for c, g in zip([*out.rgb, out.depth, out.opacity], cot)))
        results.append([np.asarray(v) for v in (*out.rgb, out.depth, out.opacity, dr.grad(field.params["sigma"]),
                                               dr.grad(field.params["rgb"]))])
    assert results[0][4][1] == 0 and results[0][0][1] == pytest.approx(0.2)      # no samples: the background
    for a, b in zip(*results):
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)
