"""pixelNeRF in 2D: projection and lookup, the im2col convolution, encoder gradients, the experiment."""

import numpy as np
import pytest

import drjit as dr
from drjit.auto.ad import Float, TensorXf, UInt32

from mitnerf.data.cameras import Cameras
from mitnerf.data.rig import look_at_2d
from mitnerf.fields.pixelnerf import (PixelNeRFConfig, PixelNeRFField, conv1d, encode, encoder_weights, im2col,
                                      lookup, make_context, project)


def two_cameras(H=10, focal=12.0):
    """Camera 0 at (4, 0) looking at the origin; camera 1 at (0, -3) looking up +y, turned by 10 degrees."""
    pos = np.array([[4.0, 0.0], [0.0, -3.0]])
    return Cameras(look_at_2d(pos, np.array([np.pi, np.pi / 2 + np.radians(10)])), focal, H)


@pytest.mark.parametrize("cam,i", [(0, 0), (0, 3), (0, 9), (1, 6)])
def test_a_point_on_a_pixel_ray_projects_to_that_pixel_and_reads_its_feature(cam, i):
    H = 10
    cams = two_cameras(H)
    o, d = cams.rays()
    x = o[cam, i, 0] + 2.5 * d[cam, i, 0]                 # 2.5 units along pixel i's centre ray
    feats = np.random.default_rng(0).standard_normal((5, 2 * H)).astype(np.float32)   # [C, V*H]
    ctx = make_context(np.zeros((2, H, 3)), cams.poses, cams.focal, feats)
    view = UInt32([cam])
    r, fwd, valid = project([Float([x[0]]), Float([x[1]])], ctx.cams, view, H, cams.focal)
    # pixel centre i is at row i + 0.5; the point is 2.5 * cos(ray angle) in front of the camera
    np.testing.assert_allclose(r.numpy(), [i + 0.5], atol=1e-4)
    np.testing.assert_allclose(fwd.numpy(), [2.5 * d[cam, i, 0] @ cams.poses[cam, :2, 0]], rtol=1e-5)
    assert bool(valid.numpy()[0])
    np.testing.assert_allclose(cams.project(x[None])[0][cam], [i + 0.5], atol=1e-9)     # numpy twin agrees
    F = lookup(ctx.features, view, r, valid, H).numpy()        # [C, 1]
    np.testing.assert_allclose(F[:, 0], feats[:, cam * H + i], atol=1e-4)


def test_lookup_interpolates_linearly_and_zeroes_invalid_points():
    H = 4
    feats = np.arange(2 * 2 * H, dtype=np.float32).reshape(2, 2 * H)   # channel c, column v*H + i: 8c + 4v + i
    F = lookup(TensorXf(feats), UInt32([1, 0, 0, 1]), Float([1.75, 0.2, 3.9, 2.0]),
               dr.auto.ad.Bool([True, True, True, False]), H).numpy()
    # row 1.75 in view 1: pixels 1 and 2 (centres 1.5, 2.5) weighted 0.75 / 0.25 -> 4 + 1.25 = 5.25;
    # rows 0.2 and 3.9 clamp to the edge pixels 0 and 3; the invalid point reads 0
    np.testing.assert_allclose(F[0], [5.25, 0.0, 3.0, 0.0], atol=1e-5)
    np.testing.assert_allclose(F[1], [13.25, 8.0, 11.0, 0.0], atol=1e-5)


def test_points_behind_or_beside_the_camera_are_invalid():
    cams = two_cameras()
    ctx = make_context(np.zeros((2, 10, 3)), cams.poses, cams.focal)
    # camera 0 at (4, 0) looks along -x: (5, 0) is behind it, (3, 2.9) is outside its field of view
    _, _, valid = project([Float([5.0, 3.0, 0.0]), Float([0.0, 2.9, 0.0])], ctx.cams, UInt32([0, 0, 0]), 10, 12.0)
    assert valid.numpy().tolist() == [False, False, True]


def numpy_conv(x, w, b, dilation):
    """Direct zero-padded cross-correlation of one view: x [C_in, H], w [C_out, C_in, K]."""
    C_out, C_in, K = w.shape
    H = x.shape[1]
    out = np.tile(b[:, None], (1, H)).astype(np.float64)
    for o in range(C_out):
        for c in range(C_in):
            for k in range(K):
                s = (k - K // 2) * dilation
                for i in range(H):
                    if 0 <= i + s < H:
                        out[o, i] += w[o, c, k] * x[c, i + s]
    return out


@pytest.mark.parametrize("dilation", [1, 3])
def test_im2col_convolution_equals_a_direct_convolution(dilation):
    rng = np.random.default_rng(1)
    V, H, C_in, C_out, K = 2, 7, 3, 4, 3
    x = rng.standard_normal((V, C_in, H)).astype(np.float32)
    w = rng.standard_normal((C_out, C_in, K)).astype(np.float32)
    b = rng.standard_normal(C_out).astype(np.float32)
    X = TensorXf(np.ascontiguousarray(x.transpose(1, 0, 2).reshape(C_in, V * H)))   # view-major columns
    assert im2col(X, H, K, dilation).shape == (C_in * K, V * H)
    Y = conv1d(TensorXf(w.reshape(C_out, C_in * K)), TensorXf(b), X, H, dilation, relu=False).numpy()
    for v in range(V):       # views never leak into each other
        np.testing.assert_allclose(Y[:, v * H:(v + 1) * H], numpy_conv(x[v], w, b, dilation), rtol=1e-5, atol=1e-5)


def test_trained_encoder_gradient_matches_finite_differences():
    cfg = PixelNeRFConfig(channels=3, dilations=(1, 2), include_rgb=False, encoder="trained")
    H = 6
    rng = np.random.default_rng(2)
    img = TensorXf(rng.uniform(0, 1, (3, 2 * H)).astype(np.float32))
    probe = rng.standard_normal((cfg.feature_size, 2 * H))
    w = encoder_weights(cfg, 3)
    w["enc.0.bias"] += 0.3                                   # keep most ReLUs active

    def loss(arrays):
        feats = encode(cfg, {k: TensorXf(v) for k, v in arrays.items()}, img, H).numpy().astype(np.float64)
        return float(np.sum(feats * probe))

    params = {k: TensorXf(v) for k, v in w.items()}
    for v in params.values():
        dr.enable_grad(v)
    L = dr.sum(encode(cfg, params, img, H).array * Float(probe.ravel().astype(np.float32)))
    dr.backward(L)
    for name in ("enc.0.weight", "enc.1.weight", "enc.0.bias"):
        g = params[name].grad.numpy()
        for idx in [(0, 0), (1, 4), (2, 7)] if g.ndim == 2 else [(0,), (2,)]:
            eps = 1e-2
            plus, minus = dict(w), dict(w)
            plus[name] = w[name].copy()
            plus[name][idx] += eps
            minus[name] = w[name].copy()
            minus[name][idx] -= eps
            fd = (loss(plus) - loss(minus)) / (2 * eps)
            np.testing.assert_allclose(g[idx], fd, rtol=2e-2, atol=2e-3)


def test_the_field_answers_for_any_number_of_views():
    cams = two_cameras(H=10)
    fld = PixelNeRFField(PixelNeRFConfig(channels=4, dilations=(1,), width=16))
    params = fld.init_params(0)
    x = [Float([0.0, 0.5, -0.3]), Float([0.0, 0.2, 0.4])]
    d = [Float([1.0, 0.0, 0.6]), Float([0.0, 1.0, 0.8])]
    for V in (1, 2):
        ctx = make_context(np.random.default_rng(V).uniform(0, 1, (V, 10, 3)), cams.poses[:V], cams.focal)
        sigma, rgb = fld.with_context(ctx).query(params, x, d)
        assert sigma.numpy().shape == (3,) and np.all(sigma.numpy() >= 0)
        assert all(0 < c.numpy().min() and c.numpy().max() < 1 for c in rgb)


@pytest.mark.parametrize("pool", ["mean", "mean_var"])
def test_pooling_over_views_ignores_their_order_and_duplicates(pool):
    # The per-view branch runs on (sample, view) pairs and is pooled per sample: a context
    # [B, A] must give the answer of [A, B], and [A, A] the answer of [A] (mean of equal
    # features is the feature; their variance is 0, as for one view).
    cams = two_cameras(H=10)
    fld = PixelNeRFField(PixelNeRFConfig(channels=4, dilations=(1, 2), width=16, pool=pool))
    params = fld.init_params(0)
    x = [Float([0.0, 0.5, -0.3, 1.0]), Float([0.0, 0.2, 0.4, -0.7])]
    d = [Float([1.0, 0.0, 0.6, -0.8]), Float([0.0, 1.0, 0.8, 0.6])]
    imgs = np.random.default_rng(3).uniform(0, 1, (2, 10, 3))

    def answer(order):
        ctx = make_context(imgs[order], cams.poses[order], cams.focal)
        sigma, rgb = fld.with_context(ctx).query(params, x, d)
        return np.stack([sigma.numpy()] + [c.numpy() for c in rgb])

    np.testing.assert_allclose(answer([1, 0]), answer([0, 1]), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(answer([0, 0]), answer([0]), rtol=1e-5, atol=1e-6)
    assert np.abs(answer([1]) - answer([0])).max() > 1e-4     # the views do matter


def test_quick_experiment_writes_its_files(tmp_path):
    from mitnerf.experiments import pixelnerf
    from mitnerf.experiments.report import SMOKE, read_csv

    tiny = pixelnerf.Config(n_outlines=2, extra_scenes=(), train_views=6, outline_test_views=4, n_seen=1, n_unseen=1,
                            eval_scenes=("bunny",), eval_train_views=8, eval_test_views=4, ks=(1, 3), draws=1,
                            k_range=(1, 3), model=PixelNeRFConfig(channels=8, dilations=(1, 2), width=32),
                            pixel_iters=10, nerf_iters=8, quick=True)   # the smallest run that writes every file
    pixelnerf.run(tiny, tmp_path)
    for name in ("results.csv", "training.csv", "psnr_vs_views.png", "strips_bunny.png", "density_bunny.png",
                 "report.md"):
        assert (tmp_path / name).stat().st_size > 0, name
    rows = read_csv(tmp_path / "results.csv")
    assert {r["method"] for r in rows} == {"pixelNeRF (frozen)", "pixelNeRF (trained)", "NeRF"}
    assert all(np.isfinite(float(r["psnr"])) for r in rows if r["group"] == "eval")
    text = (tmp_path / "report.md").read_text()
    assert "psnr_vs_views.png" in text and SMOKE in text and "reproduced" not in text   # a smoke run: no verdict
