"""The evaluation protocol: the background a fit trains and evaluates over, and what it is told."""

from __future__ import annotations

import drjit as dr
import numpy as np
import pytest

from mitnerf.data.cameras import Cameras
from mitnerf.data.dataset import Dataset, Split
from mitnerf.data.rays import background_colors
from mitnerf.train.evaluate import evaluate
from mitnerf.train.fit import resolve_background
from mitnerf.train.recipes import get_recipe
from mitnerf.train.sizing import most_vertices


def one_view() -> Split:
    """One 3D view of 3 x 3 pixels: the two left columns background (alpha 0), the right one grey 0.5, opaque."""
    a = np.tile(np.array([0.0, 0.0, 1.0], np.float32), (1, 3, 1))                   # [1, 3, 3]
    return Split(Cameras(np.eye(4)[None], 2.0, 3, 3), np.full((1, 3, 3, 3), 0.5, np.float32) * a[..., None], a)


class WhiteRenders:
    """A trained model stand-in whose every ray renders white, fully opaque."""

    def __init__(self, recipe):
        self.model_cfg, self.bound = recipe.model, 1.0

    def render(self, origins, directions, chunk=None, footprint=None, spp=1):
        n = len(origins)
        return {"rgb": np.ones((n, 3), np.float32), "depth": np.ones(n, np.float32), "opacity": np.ones(n, np.float32)}

    def n_params(self):
        return 0


@pytest.mark.parametrize("flag, line, expected", [
    (None, "background white (the dataset's", 10.7918),
    ("black", "background black (--background)", 1.2494),
    ("random", "background random for training, white for evaluation (--background)", 10.7918)])
def test_a_blender_scene_is_scored_over_white_unless_told(flag, line, expected):
    # renders all white; over white the targets are 1 (6 pixels) and 0.5 (3): squared errors 0 and 0.25 per
    # channel, MSE 0.75 / 9 = 0.08333, PSNR -10 log10(0.08333) = 10.7918 dB; over black the targets are 0 and
    # 0.5: errors 1 and 0.25, MSE (6 + 0.75) / 9 = 0.75, PSNR 1.2494 dB. A random training background is
    # evaluated over white.
    split = one_view()
    ds = Dataset({"train": split, "test": split}, 1.0, 3.0, {"format": "blender"})       # 3D, no stated colour
    recipe = get_recipe("grid-3d").override(background=flag)
    assert resolve_background(recipe, ds).startswith(line)
    rec = evaluate(WhiteRenders(recipe), ds, geometry_metrics=False)
    assert rec.psnr == pytest.approx(expected, abs=1e-4)
    assert rec.background == "white" if flag != "black" else "black"


def test_the_dataset_states_its_own_background():
    # a tiny-NeRF file is composited over black already: its default is black, not the 3D white
    split = one_view()
    ds = Dataset({"train": split}, 1.0, 3.0, {"format": "tiny_nerf", "background": [0.0, 0.0, 0.0]})
    recipe = get_recipe("grid-3d")
    assert resolve_background(recipe, ds).startswith("background black (the dataset's")
    assert recipe.model.render.background == "black"           # written into the recipe: the checkpoint records it


def test_a_random_background_is_a_colour_per_ray_and_per_step():
    split = one_view()
    rays = split.rays("random")
    a, b = rays.batch(np.array([0, 2, 0]), seed=1), rays.batch(np.array([0, 2, 0]), seed=2)
    assert not np.array_equal(a.background, b.background)          # a fresh colour per step ...
    assert not np.array_equal(a.background[0], a.background[2])    # ... and per ray, the same pixel too
    assert ((a.background >= 0) & (a.background < 1)).all()
    np.testing.assert_array_equal(a.target[0], a.background[0])     # the empty pixel shows its background
    np.testing.assert_array_equal(a.target[1], [0.5, 0.5, 0.5])     # the opaque one its colour
    np.testing.assert_array_equal(background_colors((1.0, 1.0, 1.0), 3, 2), np.ones((2, 3)))


def test_a_declared_subset_of_evenly_spaced_test_views():
    from mitnerf.train.evaluate import test_views

    np.testing.assert_array_equal(test_views(200, 0), np.arange(200))          # the default: all of them
    np.testing.assert_array_equal(test_views(200, 5), [0, 50, 100, 149, 199])   # linspace(0, 199, 5), rounded
    np.testing.assert_array_equal(test_views(3, 7), [0, 1, 2])                 # more than there are: all


def test_the_subset_is_what_is_measured():
    # three views: the middle one grey as one_view(), the others empty. Renders all white over white: the empty
    # views score no error, the grey one MSE 0.08333 (test above). Views 0 and 2 (2 of 3, evenly spaced): PSNR
    # inf; all three: MSE 0.08333 / 3 = 0.02778, PSNR 15.563 dB.
    v = one_view()
    empty = Split(v.cameras, np.zeros_like(v.color), np.zeros_like(v.alpha))
    split = Split.concatenate([empty, v, empty])
    ds = Dataset({"train": split, "test": split}, 1.0, 3.0, {"format": "blender"})
    recipe = get_recipe("grid-3d")
    resolve_background(recipe, ds)
    some = evaluate(WhiteRenders(recipe), ds, geometry_metrics=False, views=2)
    every = evaluate(WhiteRenders(recipe), ds, geometry_metrics=False)
    assert (some.views, some.split_views, some.psnr) == (2, 3, np.inf)
    assert (every.views, every.psnr) == (3, pytest.approx(15.563, abs=1e-3))
    assert some.line().startswith("test PSNR inf dB, SSIM 1.000 on 2 of 3 views")
    assert "views" not in every.line()
    np.testing.assert_array_equal(some.renders["views"], [0, 2])


def test_fit_prints_and_records_the_protocol(bunny_small, tmp_path, capsys):
    import json

    from mitnerf.cli import main
    from mitnerf.data.formats import save_dataset

    save_dataset(bunny_small, tmp_path / "ds")
    assert main(["fit", "--data", str(tmp_path / "ds"), "--iters", "5", "--field", "vanilla", "--mlp-width", "8",
                 "--mlp-depth", "1", "--samples", "8", "--test-views", "3", "--out", str(tmp_path / "run")]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[1] == ("background black (the dataset's; --background white|black|random to change); "
                        "test on 3 of 8 views (--test-views)")
    assert " on 3 of 8 views, " in lines[-1]
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert (metrics["background"], metrics["views"], metrics["split_views"]) == ("black", 3, 8)
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert manifest["dataset"]["size"] == [1, 100]                # [width, height]: a 2D view is one pixel wide


def test_rays_decoded_per_batch_train_as_rays_held_in_memory(vase_small, tmp_path):
    """A Blender folder of 8-bit images: its colours are held as the 8 bits and each batch decodes its own pixels;
    training on them matches training on every pixel's ray held as floats in memory (the path before), step for
    step (one thread: deterministic sums), to the test PSNR."""
    from mitnerf.data.formats import load_dataset, save_dataset
    from mitnerf.rng import step_seed
    from mitnerf.train.engines import make_backend

    save_dataset(vase_small, tmp_path / "ds", "blender")
    for f in (tmp_path / "ds").rglob("*_linear.npy"):          # 8-bit PNG colours only, as a Blender scene
        f.unlink()
    ds = load_dataset(tmp_path / "ds")
    assert ds["train"].eight_bit and ds["test"].eight_bit
    recipe = get_recipe("grid-3d").at_steps(12, threads=1, resolution=17, initial_resolution=17, n_coarse=16,
                                            batch_rays=256)
    resolve_background(recipe, ds)
    lazy = ds["train"].rays(recipe.model.render.render_background(), **recipe.train.ray_args())
    held = lazy.batch(np.arange(len(lazy)))                   # every pixel's ray, float, in memory
    o, d = ds["train"].cameras.rays()                           # as the cameras give them, all at once
    np.testing.assert_array_equal(held.directions, d.reshape(-1, 3).astype(np.float32))
    np.testing.assert_array_equal(held.origins, o.reshape(-1, 3).astype(np.float32))
    index = np.arange(0, len(lazy), 7)
    for name in ("origins", "directions", "target", "free", "depth", "hit"):
        np.testing.assert_array_equal(getattr(lazy.batch(index), name), getattr(held, name)[index])
    psnrs = []
    try:
        for rays in (lazy, held):
            be = make_backend("drjit", recipe.model, recipe.train, 3, ds.bound, ds.near, ds.far)
            be.set_data(rays)
            for k in range(12):
                be.read(be.step(k, step_seed(0, k), 0.05))
            psnrs.append(evaluate(be, ds, geometry_metrics=False).psnr)
    finally:
        dr.set_thread_count(2)                                  # the session's count (conftest)
    assert psnrs[0] == pytest.approx(psnrs[1], abs=1e-6) and psnrs[0] > 8, psnrs


def test_a_foreign_scene_is_bounded_by_its_visual_hull(vase_small, tmp_path):
    """A Blender folder without our provenance file: the bound comes from the box around the training views'
    visual hull (alpha), tighter than the camera distances' guess and still around every surface point the depth
    maps see."""
    from mitnerf.data.formats import load_dataset, save_dataset

    save_dataset(vase_small, tmp_path / "ds", "blender")
    (tmp_path / "ds" / "mitnerf.json").unlink()                  # as anyone's Blender scene
    ds = load_dataset(tmp_path / "ds")
    guess = 1.1 * (np.median(np.linalg.norm(ds["train"].cameras.origins, axis=1)) - ds.near)
    surface = []
    for name in ("train", "test"):
        o, d = vase_small[name].cameras.rays()
        hit = np.isfinite(vase_small[name].depth)
        surface.append((o + vase_small[name].depth[..., None] * d)[hit])
    surface = np.concatenate(surface)
    assert 1.1 * np.abs(surface).max() <= ds.bound < 0.8 * guess
    lo, hi = np.array(ds.hull_box[:3]), np.array(ds.hull_box[3:])         # the box holds every surface point
    assert (surface >= lo).all() and (surface <= hi).all() and np.abs(ds.hull_box).max() * 1.1 == ds.bound
    sized = get_recipe("grid-3d").sized(ds).model.field_args             # the grid spans that box
    assert sized["box"] == ds.hull_box and sized["resolution"] >= sized["initial_resolution"]


def views_at(focal: float, n: int = 3) -> Dataset:
    """``n`` 3D cameras 4 units from the origin with ``focal`` (pixels), our object (bound 1.1), near 2, far 6."""
    poses = np.stack([np.eye(4)] * n)
    poses[:, 2, 3] = 4.0
    split = Split(Cameras(poses, focal, 2, 2), np.zeros((n, 2, 2, 3), np.float32), np.ones((n, 2, 2), np.float32))
    return Dataset({"train": split, "test": split}, 2.0, 6.0, {"kind": "3d"})


@pytest.mark.parametrize("focal, final, start, bins, cells, levels", [
    # a pixel's footprint at the origin: 4 / focal; the bound 1.1 spans 2.2 / footprint lattice spacings, 1.5 per
    # pixel: 3.3 focal / 4 + 1 vertices. grid-3d: at most 161, two doublings; one bin per spacing over [2, 6]: 4 (R -
    # 1) / 2.2 bins; a cell per two spacings. hashlinear-3d: at most 385, three doublings, a level each
    (138.9, 117, 30, 211, 58, (15, 29, 57, 113)),    # 115.6 vertices: 29 * 4 + 1 = 117; 14 * 8 + 1 = 113
    (277.8, 161, 41, 291, 80, (30, 59, 117, 233)),   # 230 vertices (< 277.9, below): 161 = 40 * 4 + 1; 29 * 8 + 1
])
def test_a_recipe_takes_its_lattice_and_samples_from_the_data(focal, final, start, bins, cells, levels):
    recipe = get_recipe("grid-3d").sized(views_at(focal))
    args, occ = recipe.model.field_args, recipe.model.render.occupancy
    assert (args["resolution"], args["initial_resolution"], occ.march_bins, occ.resolution) == (final, start, bins,
                                                                                                cells)
    assert recipe.sizing is None and recipe.name == "grid-3d"                  # sized once, under its own name
    assert get_recipe("hashlinear-3d").sized(views_at(focal)).model.field_args["resolutions"] == levels


def test_a_size_set_on_the_recipe_stays():
    recipe = get_recipe("grid-3d").override(resolution=65).sized(views_at(555.5))
    args = recipe.model.field_args
    assert (args["resolution"], args["initial_resolution"]) == (65, 17)        # 65 = 16 * 4 + 1: from 17
    assert recipe.model.render.occupancy.march_bins == 117                     # ceil(4 * 64 / 2.2)


def test_views_finer_than_the_cap_refine_the_density_and_keep_the_floats_of_the_cube():
    """grid-3d on views asking for 459 vertices a side (focal 555.5): a vertex holds 12 colour floats and about 2^3
    density ones, so a refined lattice keeps 13 / 20 of the 161^3 cube's vertices, 161 * 0.65^(1/3) = 139.46 a
    side, whose density would have 2 * 138.46 + 1 = 277.9: the views ask for more, so the density is refined.
    35 * 4 + 1 = 141 (c rounded), its density 2 * 140 + 1 = 281; the bins follow the density's spacing, one per
    spacing: ceil(4 * 2 * 140 / 2.2) = 510; the samples stay 64; a cell per two colour spacings: 70. Set to 1, the
    density keeps the colour's lattice: the table's 161 and 291 bins. Set to 2 on views asking for 230 (focal
    277.8, fewer than 277.9), the density is refined all the same, on the same 141."""
    recipe = get_recipe("grid-3d").sized(views_at(555.5))
    args, render = recipe.model.field_args, recipe.model.render
    assert (args["resolution"], args["initial_resolution"], args["density_refine"]) == (141, 36, 2)
    assert (render.occupancy.march_bins, render.n_coarse, render.occupancy.resolution) == (510, 64, 70)
    assert recipe.model.field_config(3).refined_share == 13 / 20
    assert recipe.name == "grid-3d"
    one = get_recipe("grid-3d").override(density_refine=1).sized(views_at(555.5))
    assert (one.model.field_args["resolution"], one.model.render.occupancy.march_bins) == (161, 291)
    assert get_recipe("hashlinear-3d").sized(views_at(555.5)).model.field_args["resolutions"] == (49, 97, 193, 385)
    two = get_recipe("grid-3d").override(density_refine=2).sized(views_at(277.8))
    assert (two.model.field_args["resolution"], two.model.field_args["initial_resolution"]) == (141, 36)
    assert (two.model.render.occupancy.march_bins, two.model.render.n_coarse) == (510, 64)


def test_a_refined_lattice_is_sized_within_the_density_limit():
    """A density refined 3 times may have 1025 vertices a side at most, so its colour lattice 1024 // 3 + 1 = 342:
    views asking for 4126 vertices (focal 5000), the cap raised past that (max_resolution 2000), three doublings:
    341 / 8 = 42.6 would round to 43, 43 * 8 + 1 = 345 (a density of 1033, refused); it takes 42: 337 from 43."""
    import dataclasses

    recipe = get_recipe("grid-3d").override(density_refine=3)
    recipe.sizing = dataclasses.replace(recipe.sizing, max_resolution=2000, doublings=3)
    sized = recipe.sized(views_at(5000.0))
    args = sized.model.field_args
    assert (args["resolution"], args["initial_resolution"], args["density_refine"]) == (337, 43, 3)
    assert sized.model.field_config(3).density_lattice(337) == [1009] * 3                 # 3 * 336 + 1
    assert most_vertices(3) == 342 and most_vertices(2) == 513 and most_vertices(1) == 513


def test_a_grid_spans_the_data_box_with_as_many_vertices_as_the_cube():
    """A box of 1 x 2 x 0.5 (shares 0.5, 1, 0.25: an eighth of its longest side's cube) under the cap of 161^3 vertices:
    its fullest axis gets 160 / 0.5 + 1 = 321 (the views would give 2 / (4 / 555.5) * 1.5 + 1 = 418), so 161 x 321 x
    81 vertices; one bin per spacing (2 / 320) over [2, 6]: 640; a cell per two spacings: 176, at most 128."""
    ds = views_at(555.5)
    ds.hull_box = (-0.5, -1.0, -0.25, 0.5, 1.0, 0.25)
    recipe = get_recipe("grid-3d").sized(ds)
    args, occ = recipe.model.field_args, recipe.model.render.occupancy
    assert (args["box"], args["resolution"], args["initial_resolution"]) == (ds.hull_box, 321, 81)
    assert (occ.march_bins, occ.resolution) == (640, 128)
    from mitnerf.fields.grid import GridConfig

    assert GridConfig(dim=3, **args).lattice(321) == [161, 321, 81]


def test_the_total_variation_weakens_where_the_views_have_more_pixels_than_the_lattice_vertices():
    """The box of the test above: 161 x 321 x 81 = 4186161 vertices. 3 views of 2 x 2 pixels keep grid-3d's weights
    (tv 1e-5, colour 3e-4); 100 views of 160 x 160 (2560000 pixels: 1.6352 vertices a pixel, over 1) keep them too;
    400 views of 160 x 160 (10240000 pixels: 0.408805 a pixel, under tv_reference 1) scale both by 0.408805 (tv
    4.08805e-6, colour 1.226415e-4) and mine their batch (mining 0.8, 8192 rays), or without mining take twice the
    batch (16384 rays); a weight or a batch set on the recipe stays."""
    def box_views(n: int, size: int) -> Dataset:
        poses = np.stack([np.eye(4)] * n)
        poses[:, 2, 3] = 4.0
        split = Split(Cameras(poses, 555.5, size, size), np.zeros((n, size, size, 3), np.uint8),
                      np.zeros((n, size, size), np.uint8))
        ds = Dataset({"train": split, "test": split}, 2.0, 6.0, {"kind": "3d"})
        ds.hull_box = (-0.5, -1.0, -0.25, 0.5, 1.0, 0.25)
        return ds

    def weights(ds, **settings):
        recipe = get_recipe("grid-3d").override(**settings).sized(ds)
        args = recipe.model.field_args
        return args["tv_weight"], args["tv_color_weight"], recipe.train.batch_rays, recipe.train.mining

    np.testing.assert_allclose(weights(box_views(3, 2)), (1e-5, 3e-4, 8192, 0))
    np.testing.assert_allclose(weights(box_views(100, 160)), (1e-5, 3e-4, 8192, 0))
    many = box_views(400, 160)
    np.testing.assert_allclose(weights(many), (4.08805e-6, 1.226415e-4, 8192, 0.8), rtol=1e-5)
    np.testing.assert_allclose(weights(many, mining=0), (4.08805e-6, 1.226415e-4, 16384, 0), rtol=1e-5)
    np.testing.assert_allclose(weights(many, mining=0.5), (4.08805e-6, 1.226415e-4, 8192, 0.5), rtol=1e-5)
    np.testing.assert_allclose(weights(many, tv_weight=2e-5, batch_rays=4096), (2e-5, 1.226415e-4, 4096, 0.8),
                               rtol=1e-5)


def test_a_setting_at_the_recipes_own_value_renames_it_only_where_it_fixes_a_size():
    """``--batch 8192`` on grid-3d fixes its batch against the data (the lego's would double): grid-3d+; on
    hashlinear-3d, which sizes no batch, the same run under the same name."""
    assert get_recipe("grid-3d").override(batch_rays=8192).name == "grid-3d+"
    assert get_recipe("hashlinear-3d").override(batch_rays=8192, tv_color_weight=3e-4).name == "hashlinear-3d"


def forward_views(width: int, height: int) -> Dataset:
    """One forward-facing view of ``width`` x ``height`` pixels (the sizing reads only its size)."""
    split = Split(Cameras(np.eye(4)[None], 400.0, height, width), np.zeros((1, height, width, 3), np.float32),
                  np.ones((1, height, width), np.float32))
    return Dataset({"train": split, "test": split}, 1.0, 10.0, {"kind": "3d"})


@pytest.mark.parametrize("width, height, final, start, lattice", [
    # x' takes a vertex a pixel of the width: 504 + 1 = 505; 504 / 4 = 126, so 126 * 4 + 1 = 505 from 127; the cells
    # in the proportions 504 : 378 : 63 (z', an eighth of the width): 378 + 1 = 379, 504 / 8 + 1 = 64
    (504, 378, 505, 127, [505, 379, 64]),
    # portrait: the fullest axis is y', 504 pixels: the same 505 vertices, x' 379, z' 378 / 8 + 1 = 48.25: 48
    (378, 504, 505, 127, [379, 505, 48]),
    # 1008 x 756 would take 1009; 241^3 vertices at most allows 240 / (0.75 / 8)^(1/3) + 1 = 529.3, and a 3D grid has
    # at most 513 a side: 128 * 4 + 1 from 129
    (1008, 756, 513, 129, [513, 385, 65]),
])
def test_a_forward_facing_grid_takes_its_lattice_from_the_images(width, height, final, start, lattice):
    from mitnerf.fields.grid import GridConfig

    args = get_recipe("grid-forward").sized(forward_views(width, height)).model.field_args
    assert (args["resolution"], args["initial_resolution"]) == (final, start)
    assert GridConfig(dim=3, **args).lattice(final) == lattice
    kept = get_recipe("grid-forward").override(cells=[4, 3, 1]).sized(forward_views(504, 378)).model.field_args
    assert kept["cells"] == [4, 3, 1] and kept["resolution"] == 421   # 240 / (3 / 16)^(1/3) + 1 = 420.3: 105 * 4 + 1
    cube = get_recipe("grid-forward").override(nulls=True, cells=None).sized(forward_views(504, 378)).model.field_args
    assert cube["cells"] is None and cube["resolution"] == 241        # the cube: 241^3 at most


@pytest.mark.parametrize("scene, data, default, probes, views", [
    # fern's 504 x 378 views: 505 across from 127 (two doublings of 126); 126 // 2 = 63: 253 from 64; 126 // 4 = 31:
    # 125 from 32, in the cells' proportions 504 : 378 : 63, 94 and 17 vertices (124 * 0.75 + 1, 124 / 8 + 1)
    ("forward", lambda: forward_views(504, 378), (505, 127), [(125, 32, [125, 94, 17]), (253, 64, [253, 190, 33])],
     5),                                 # validated on 2^20 pixels: 1048576 // (504 * 378) = 5.5 views

    # grid-unbounded's own 193 from 49 (two doublings of 48): 97 from 25, 49 from 13
    ("unbounded", lambda: forward_views(504, 378), (193, 49), [(49, 13, [49] * 3), (97, 25, [97] * 3)],
     5),
    # an object seen at focal 555.5 (its density refined, above): 141 from 36; 35 // 4 = 8: 33 from 9, 35 // 2 = 17:
    # 69 from 18, their densities refined as the default's
    ("object", lambda: views_at(555.5), (141, 36), [(33, 9, [33] * 3, 2), (69, 18, [69] * 3, 2)],
     1 << 18),                           # views of 2 x 2 pixels: as many as there are, up to 2^20 / 4
    # focal 10: 3.3 * 10 / 4 + 1 = 9.25 vertices, 9 from 3; two spacings halved is one: no coarser probe
    ("object", lambda: views_at(10.0), (9, 3), [], 1 << 18),
])
def test_fit_auto_probes_the_default_first_then_its_lattice_with_fewer_spacings(scene, data, default, probes, views):
    """``fit --auto`` probes the scene's default recipe first, sized from the data (a search cut short by its budget
    still has it to choose), then that lattice with half and a quarter of its spacings, coarse to fine with the
    same doublings, whatever the views' size; each probe is scored on about 2^20 pixels of validation views."""
    from mitnerf.fields.grid import GridConfig
    from mitnerf.train.auto import AutoConfig, candidates, probe_recipe

    ds, cfg = data(), AutoConfig(scene=scene)
    ds = Dataset({**ds.splits, "val": ds["train"]}, ds.near, ds.far, ds.meta)        # the probes validate on it
    got = candidates(ds, cfg)
    assert got[0] == ("grid", {}) and [c[0] for c in got].count("grid") == 1 + len(probes)
    got = got[:1 + len(probes)]                                    # the coarser grids next, before other families'
    assert all(c[0] == "grid" for c in got)
    first = probe_recipe(*got[0], ds, cfg).sized(ds).model.field_args
    assert (first["resolution"], first["initial_resolution"]) == default
    assert probe_recipe(*got[0], ds, cfg).train.val_views == views
    sized = [probe_recipe(*c, ds, cfg).sized(ds).model.field_args for c in got[1:]]
    assert [(a["resolution"], a["initial_resolution"], GridConfig(dim=3, **a).lattice(a["resolution"]))
            + ((a["density_refine"],) if "density_refine" in a else ()) for a in sized] == probes


def test_fit_auto_sizes_every_probe_with_the_density_refinement_the_user_typed():
    """``fit --auto --set density_refine=1`` on views that would refine it (focal 555.5): every grid probe keeps one
    lattice, sized as one (161 from 41 over 291 bins, not the refined 141 over 510 bins), the coarser ones from it
    (41 and 81, the table's); families without the setting are probed as they are."""
    from mitnerf.train.auto import AutoConfig, candidates, pinned_for, probe_recipe

    ds = views_at(555.5)
    ds = Dataset({**ds.splits, "val": ds["train"]}, ds.near, ds.far, ds.meta)
    pinned, cfg = {"density_refine": 1, "lr": 0.1}, AutoConfig(scene="object")
    got = candidates(ds, cfg, pinned)
    sized = [probe_recipe(*c, ds, cfg, pinned).sized(ds) for c in got]
    grids = [(r.model.field_args["resolution"], r.model.render.occupancy.march_bins) for r in sized
             if r.model.field == "grid"]
    assert grids[:3] == [(161, 291), (41, 73), (81, 146)]          # ceil(4 (R - 1) / 2.2): one bin a spacing
    assert all(r.model.field_args.get("density_refine", 1) == 1 for r in sized if r.model.field == "grid")
    assert pinned_for("grid", pinned) == {"density_refine": 1} and pinned_for("vanilla", pinned) == {}
    assert any(r.model.field != "grid" for r in sized)


def test_a_recipe_is_sized_for_cameras_with_a_lens():
    """Sizing reads the focal lengths of any camera (per-frame intrinsics, distortion): the same lattice as the
    pinhole views of the same focal (``views_at(555.5)``: 141, its density refined)."""
    ds = views_at(555.5)
    cams = ds["train"].cameras
    lens = Cameras(cams.poses, cams.fx, 2, 2, cams.fy, cams.cx, cams.cy, np.tile([0.01, 0, 0, 0, 0], (3, 1)))
    split = Split(lens, np.zeros((3, 2, 2, 3), np.float32), np.ones((3, 2, 2), np.float32))
    sized = get_recipe("grid-3d").sized(Dataset({"train": split, "test": split}, 2.0, 6.0, {"kind": "3d"}))
    assert (sized.model.field_args["resolution"], sized.model.field_args["density_refine"]) == (141, 2)


def test_views_are_read_at_their_own_size_up_to_the_cap(vase_small, tmp_path, monkeypatch):
    """6 training views of 24 x 24 hold 3456 pixels: under the cap they are read as they are; with the cap at 1000,
    ceil(sqrt(3456 / 1000)) = 2 times smaller (12 x 12) and said; --downscale overrides the cap."""
    from mitnerf.cli import fit_cmd
    from mitnerf.data.formats import save_dataset

    save_dataset(vase_small, tmp_path / "ds", "blender")
    ds, line = fit_cmd.read_views(tmp_path / "ds", None)
    assert (ds["train"].cameras.width, ds["test"].cameras.width, line) == (24, 24, None)
    monkeypatch.setattr(fit_cmd, "MAX_TRAIN_PIXELS", 1000)
    ds, line = fit_cmd.read_views(tmp_path / "ds", None)
    assert (ds["train"].cameras.width, ds["test"].cameras.width) == (12, 12)
    assert line == "views: read 2 times smaller, 12 x 12 (the 6 training views hold 3,456 pixels; --downscale 1 " \
                   "keeps them all)"
    assert fit_cmd.read_views(tmp_path / "ds", 1)[0]["train"].cameras.width == 24
