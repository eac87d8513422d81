"""Scene library: the brick's printed detail, materials and their highlights, view dependence,
the environment light, noisy ground truth at low spp, and Mitsuba's AOV depth against ours."""

import numpy as np
import pytest
from scipy.ndimage import binary_erosion

from mitnerf.data.cameras import Cameras
from mitnerf.data.rig import RigConfig, look_at_2d, make_rig
from mitnerf.errors import DataError
from mitnerf.scenes.gt_render import RenderSettings, aov_depth, exact_depth, render_color
from mitnerf.scenes.registry import SCENES_XML, get_scene


def views(dim, n=3, res=32, seed=1):
    return make_rig(RigConfig(dim=dim, n_train=n, n_val=0, n_test=0, resolution=res, seed=seed)).train


def render(info, cams, scene=None, **settings):
    settings = {"integrator": "path" if info.lighting == "env" else "all_lights", "spp": 16, **settings}
    return render_color(scene or info.load(), cams.mitsuba_frames(), cams.fov, cams.height, cams.width,
                        RenderSettings(**settings))


def inner_mask(scene, cams):
    """Pixels whose pixel-centre ray and all neighbours' hit the object (no silhouettes)."""
    _, mask = exact_depth(scene, *cams.rays())
    return np.stack([binary_erosion(m, np.ones((3, 3) if cams.dim == 3 else (3, 1)), border_value=0) for m in mask])


def detail(rgb, inner):
    """Mean squared difference of neighbouring pixels inside the object: printed detail."""
    g = [np.diff(rgb, axis=1)[inner[:, 1:] & inner[:, :-1]]]
    if rgb.shape[2] > 1:
        g.append(np.diff(rgb, axis=2)[inner[:, :, 1:] & inner[:, :, :-1]])
    return float(np.mean(np.concatenate(g) ** 2))


def psnr(a, b):
    return 10 * np.log10(1.0 / np.mean((a - b) ** 2))


def test_brick_prints_are_sharper_than_the_vase():
    cams = views(3, n=3, res=100)
    energy = {}
    for name in ("brick", "vase"):
        info = get_scene(name)
        scene = info.load()
        rgb, alpha = render(info, cams, scene)
        inner = inner_mask(scene, cams)
        assert inner.mean() > 0.08                              # the object fills the views
        energy[name] = detail(rgb, inner)
    assert energy["brick"] > 3 * energy["vase"], energy                # measured: 4.2x


def test_textured_outline_has_stripes():
    cams = views(2, n=12, res=100)
    energy = {}
    for name in ("bunny", "bunny_textured"):
        info = get_scene(name)
        scene = info.load()
        energy[name] = detail(render(info, cams, scene)[0], inner_mask(scene, cams))
    assert energy["bunny_textured"] > 10 * energy["bunny"], energy


@pytest.mark.parametrize("base, dim", [("bunny", 2), ("vase", 3)])
def test_glossy_materials_add_highlights(base, dim):
    cams = views(dim, n=12 if dim == 2 else 3, res=100 if dim == 2 else 32)
    diffuse, alpha = render(get_scene(base), cams)
    for material in ("roughplastic", "roughconductor"):
        rgb, _ = render(get_scene(base, material=material), cams)
        assert rgb.max() > 1.2 * diffuse.max(), material          # highlights (2D roughplastic: 0.64 against 0.48)
        assert np.abs(rgb - diffuse)[alpha > 0.5].mean() > 0.02, material


def test_roughness_sets_the_highlight_width():
    """GGX's peak grows as 1 / roughness^2: a sharp highlight outshines a broad one; the default is 0.25."""
    cams = views(2, n=12, res=100)
    sharp, _ = render(get_scene("bunny_glossy_r0.05"), cams)
    broad, _ = render(get_scene("bunny", material="roughplastic", roughness=0.5), cams)
    assert sharp.max() > 1.5 * broad.max()
    np.testing.assert_array_equal(render(get_scene("bunny_glossy"), cams)[0],
                                  render(get_scene("bunny_glossy_r0.25"), cams)[0])


def test_plastic_needs_and_shows_the_sun():
    cams = views(2, n=12, res=100)
    diffuse, _ = render(get_scene("bunny", env=True), cams, spp=32)
    plastic, _ = render(get_scene("bunny_plastic_env"), cams, spp=32)
    assert plastic.max() > 1.5 * diffuse.max()                  # the sun's mirror image


def test_glossy_colour_depends_on_the_view_direction():
    """One point on the square's right wall (x = 0.8) seen along two directions."""
    p = np.array([0.8, 0.1])
    angles = np.radians([2.0, 50.0])
    pos = p + 3.0 * np.stack([np.cos(angles), np.sin(angles)], 1)
    cams = Cameras(look_at_2d(pos, angles + np.pi), 2000.0, height=1)   # one narrow pixel each
    o, d = cams.rays()
    np.testing.assert_allclose(o[:, 0, 0] + exact_depth(get_scene("square").load(), o, d)[0][:, 0, 0, None]
                               * d[:, 0, 0], [p, p], atol=1e-5)
    for material, differs in (("diffuse", False), ("roughplastic", True), ("roughconductor", True)):
        rgb, _ = render(get_scene("square", material=material), cams, spp=4)
        gap = np.abs(rgb[0] - rgb[1]).max()
        assert (gap > 0.05) if differs else (gap < 1e-3), (material, gap)


@pytest.mark.parametrize("name", ["bunny_env", "vase_roughconductor_env"])
def test_environment_light_renders_with_path_only(name):
    info = get_scene(name)
    dim = 2 if info.kind == "2d" else 3
    cams = views(dim, n=8 if dim == 2 else 2, res=64 if dim == 2 else 32)
    scene = info.load()
    rgb, alpha = render(info, cams, scene, spp=16)
    _, mask = exact_depth(scene, *cams.rays())
    assert np.isfinite(rgb).all() and 0.03 < rgb[mask].mean() < 1.0
    assert np.abs(alpha.mean() - mask.mean()) < 0.03           # coverage, not the sky
    assert rgb[alpha == 0].max(initial=0) == 0                  # misses stay black
    with pytest.raises(DataError, match="path integrator"):
        render(info, cams, scene, integrator="all_lights")


@pytest.mark.parametrize("kind", ["2d", "3d"])
def test_the_sun_shines_from_where_the_sky_image_puts_it(kind):
    import mitsuba as mi

    from mitnerf.scenes import looks

    sky = mi.load_dict(looks.env_emitter(kind))
    el, az = np.radians(looks.SUN_ELEVATION[kind]), np.radians(looks.SUN_AZIMUTH)
    radiance = []
    for d in ([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], [0, 0, 1], [0, 0, -1]):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(-np.asarray(d, np.float32))         # looking from the scene towards d
        radiance.append(np.asarray(sky.eval(si)).ravel())
    sun, zenith, nadir = radiance
    assert sun.min() > 200 and zenith[2] > zenith[0] > nadir[2]   # bright sun, blue sky above the ground


def test_low_spp_ground_truth_is_noisy():
    info = get_scene("vase_env")
    scene = info.load()
    cams = views(3, n=2, res=32)
    low = [render(info, cams, scene, spp=4, seed=s)[0] for s in (1, 2)]
    high = [render(info, cams, scene, spp=64, seed=s)[0] for s in (1, 2)]
    assert psnr(*low) < 38 and psnr(*high) > psnr(*low) + 8


@pytest.mark.parametrize("name", ["bunny", "brick_glossy_env"])
def test_mitsuba_aov_depth_is_our_exact_depth(name):
    info = get_scene(name)
    dim = 2 if info.kind == "2d" else 3
    cams = views(dim, n=6 if dim == 2 else 2, res=32 if dim == 2 else 24)
    scene = info.load()
    depth, mask = exact_depth(scene, *cams.rays())
    aov = aov_depth(scene, cams.mitsuba_frames(), cams.fov, cams.height, cams.width)
    inner = inner_mask(scene, cams)
    assert inner.sum() > 50
    np.testing.assert_allclose(aov[inner], depth[inner], atol=1e-4, rtol=0)
    assert (aov[~mask] == 0).all()


def test_variant_names_and_refused_looks():
    info = get_scene("bunny_glossy")
    assert (info.name, info.material, info.lighting) == ("bunny_roughplastic", "roughplastic", "points")
    info = get_scene("square_concave_env", material="roughconductor")
    assert (info.name, info.kind, info.lighting) == ("square_concave_roughconductor_env", "2d", "env")
    assert get_scene("brick").texture.is_file()
    for args, words in [(("bunny",), dict(material="plastic")), (("vase_textured",), {}),
                        (("bunny_plastic_env",), dict(material="roughplastic")),
                        ((str(SCENES_XML / "square.xml"),), dict(env=True))]:
        with pytest.raises(DataError):
            get_scene(*args, **words)


def test_roughness_names_and_refusals():
    info = get_scene("vase_roughconductor_r0.1_env")
    assert (info.name, info.material, info.roughness, info.lighting) == (
        "vase_roughconductor_r0.1_env", "roughconductor", 0.1, "env")
    assert get_scene("bunny_glossy", roughness=0.3).name == "bunny_roughplastic_r0.3"
    assert get_scene("bunny_glossy").roughness is None                 # the material's default
    for args, words in [(("bunny",), dict(roughness=0.3)),               # diffuse has no roughness
                        (("bunny_plastic_r0.3_env",), {}),                # nor has smooth plastic
                        (("bunny_glossy_r0",), {}), (("bunny_glossy_r1.5",), {}), (("bunny_glossy_rnan",), {}),
                        (("bunny_glossy_rough",), {}),                    # not a number: an unknown scene
                        (("bunny_glossy_r0.3",), dict(roughness=0.2))]:   # two roughnesses
        with pytest.raises(DataError):
            get_scene(*args, **words)


def test_dataset_command_records_the_look(tmp_path):
    from mitnerf.cli import main
    from mitnerf.data.formats import load_dataset

    assert main(["dataset", "--scene", "brick", "--material", "roughplastic", "--out", str(tmp_path / "b"),
                 "--views", "2", "--val", "1", "--test", "1", "--image-size", "16"]) == 0
    meta = load_dataset(tmp_path / "b").meta
    assert (meta["scene"], meta["material"], meta["lighting"]) == ("brick_roughplastic", "roughplastic", "points")
    assert main(["dataset", "--scene", "square", "--env", "--spp", "4", "--out", str(tmp_path / "s"),
                 "--views", "2", "--val", "1", "--test", "1"]) == 0
    meta = load_dataset(tmp_path / "s").meta
    assert (meta["lighting"], meta["render"]["integrator"]) == ("env", "path")
    assert main(["dataset", "--scene", "square_glossy", "--roughness", "0.3", "--out", str(tmp_path / "r"),
                 "--views", "2", "--val", "1", "--test", "1", "--image-size", "16"]) == 0
    meta = load_dataset(tmp_path / "r").meta
    assert (meta["scene"], meta["roughness"]) == ("square_roughplastic_r0.3", 0.3)
    for bad in (["--scene", "square", "--roughness", "0.3"], ["--scene", "square_glossy", "--roughness", "0"]):
        assert main(["dataset", *bad, "--out", str(tmp_path / "y"), "--views", "2"]) == 2
        assert not (tmp_path / "y").exists()
    assert main(["dataset", "--scene", "square", "--env", "--integrator", "all_lights", "--out",
                 str(tmp_path / "x"), "--views", "2"]) == 2
    assert not (tmp_path / "x").exists()
