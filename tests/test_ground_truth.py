"""Ground truth: exact depth, masks, convergence, and the camera convention against Mitsuba."""

import numpy as np
import pytest

from mitnerf.data.rig import RigConfig, make_rig, noise_preset
from mitnerf.scenes.objects3d import OBJECTS_3D
from mitnerf.scenes.registry import SCENES_2D, get_scene
from mitnerf.scenes.gt_render import RenderSettings, compare_variants, exact_depth, render_color


@pytest.mark.parametrize("name", SCENES_2D)
def test_2d_depth_and_mask_match_the_analytic_outline(name):
    info = get_scene(name)
    cams = make_rig(RigConfig(dim=2, n_train=40, n_val=0, n_test=0, seed=7, **noise_preset(2.0))).train
    depth, mask = exact_depth(info.load(), *cams.rays())
    o, d = cams.rays()
    ref = info.polygon.intersect(o.reshape(-1, 2), d.reshape(-1, 2)).reshape(depth.shape)
    np.testing.assert_array_equal(mask, np.isfinite(ref))
    assert 0.1 < mask.mean() < 0.95                       # the views see object and background
    np.testing.assert_allclose(depth[mask], ref[mask], atol=1e-4, rtol=0)


def psnr(a, b):
    return 10 * np.log10(1.0 / np.mean((a - b) ** 2))


@pytest.mark.parametrize("name", SCENES_2D + OBJECTS_3D)
def test_colour_is_converged(name):
    """Default spp against 4x the samples: >= 50 dB (a 16-spp MC render would be ~28 dB)."""
    info = get_scene(name)
    dim = 2 if info.kind == "2d" else 3
    cams = make_rig(RigConfig(dim=dim, n_train=6 if dim == 3 else 30, n_val=0, n_test=0,
                              resolution=48 if dim == 3 else 100, seed=1)).train
    scene = info.load()
    spp = RenderSettings().spp
    view = (cams.mitsuba_frames(), cams.fov, cams.height, cams.width)
    a, alpha = render_color(scene, *view, RenderSettings(seed=1, spp=spp))
    b, _ = render_color(scene, *view, RenderSettings(seed=2, spp=4 * spp))
    assert alpha.mean() > 0.02                            # something is in view
    assert psnr(a, b) >= 50.0


def mitsuba_pixel_rays(cams):
    """Directions Mitsuba's own perspective sensors shoot through our pixel centres."""
    import mitsuba as mi

    fw, fh = (cams.height, 1) if cams.dim == 2 else (cams.width, cams.height)
    out = []
    for frame in cams.mitsuba_frames():
        sensor = mi.load_dict({"type": "perspective", "fov": cams.fov, "fov_axis": "x",
                               "to_world": mi.ScalarTransform4f(frame.tolist()),
                               "film": {"type": "hdrfilm", "width": fw, "height": fh}})
        x, y = np.meshgrid((np.arange(fw) + 0.5) / fw, (np.arange(fh) + 0.5) / fh)
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(x.ravel(), y.ravel()), mi.Point2f(0.5, 0.5))
        out.append(np.stack([np.asarray(ray.d[i]) for i in range(3)], -1).reshape(fh, fw, 3))
    out = np.stack(out)
    return out.transpose(0, 2, 1, 3)[..., :2] if cams.dim == 2 else out


@pytest.mark.parametrize("dim", [2, 3])
def test_our_pixel_rays_are_mitsubas_pixel_rays(dim):
    cams = make_rig(RigConfig(dim=dim, n_train=3, n_val=0, n_test=0, resolution=16, seed=2,
                              **noise_preset(1.0))).train
    _, d = cams.rays()
    np.testing.assert_allclose(mitsuba_pixel_rays(cams), d, atol=2e-6)


@pytest.mark.parametrize("name", ["square", "vase"])
def test_scalar_and_llvm_variants_agree(name):
    """Two converged renders of different sample sequences: colour within 35 dB PSNR; depth and masks of
    the same pixel-centre rays equal to float precision."""
    import mitsuba as mi

    scene = get_scene(name)
    dim = 2 if scene.kind == "2d" else 3
    cams = make_rig(RigConfig(dim=dim, n_train=2, n_val=0, n_test=0, resolution=48 if dim == 2 else 12,
                              radius_std=0.1, angle_std=2, seed=1)).train
    try:
        c = compare_variants(scene.load, cams.mitsuba_frames(), cams.fov, cams.height, cams.width, *cams.rays(), 16)
    finally:
        mi.set_variant("llvm_ad_rgb")
        mi.set_log_level(mi.LogLevel.Warn)
    assert c["psnr"] >= 35 and c["depth_error"] <= 1e-4 and c["masks_equal"], c
