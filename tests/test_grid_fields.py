"""Grid and hash-grid fields, and auto-sizing (empty-space skipping: test_occupancy.py)."""

import drjit as dr
import numpy as np
import pytest
from drjit.auto.ad import Float

from mitnerf.fields.grid import GridConfig, GridField
from mitnerf.fields.hashenc import hash_encode, hash_layout


@pytest.mark.parametrize("dim, levels, log2_T, base, scale", [(2, 12, 12, 8, 1.5), (3, 6, 14, 16, 1.7)])
def test_our_hash_encoding_is_drjits(dim, levels, log2_T, base, scale):
    import drjit.nn as nn

    enc = nn.HashGridEncoding(Float, dim, n_levels=levels, n_features_per_level=2, hashmap_size=2 ** log2_T,
                              base_resolution=base, per_level_scale=scale, rng=dr.rng(seed=0))
    layout = hash_layout(dim, levels, 2, 2 ** log2_T, base, scale)
    assert layout.n_params == enc.n_params
    table = Float(np.random.default_rng(1).normal(size=enc.n_params).astype(np.float32))
    enc.data = table
    x = [Float(np.random.default_rng(2 + k).random(2000).astype(np.float32)) for k in range(dim)]
    ours = np.array([np.asarray(v) for v in hash_encode(table, x, layout)])
    theirs = np.array([np.asarray(v) for v in enc(x)])
    np.testing.assert_allclose(ours, theirs, atol=5e-4)   # fp32 rounding; values are O(1)


def test_grid_resize_keeps_a_linear_field():
    # bilinear interpolation reproduces linear functions exactly, so upsampling a grid that
    # holds f(x, y) = 0.3 x - 0.2 y + 0.1 must give the same function at any point
    f = GridField(GridConfig(dim=2, resolution=33, initial_resolution=9, density_scale=1.0, bound=1.5))
    u = np.linspace(-1.5, 1.5, 9, dtype=np.float32)
    X, Y = np.meshgrid(u, u)                           # row = y, column = x
    lin = 0.3 * X - 0.2 * Y + 0.1
    params = {"density": Float(lin.ravel()), "color": Float(np.zeros(81 * 3, np.float32))}
    big = f.resize(params, 33)
    assert dr.width(big["density"]) == 33 * 33
    pts = np.random.default_rng(0).uniform(-1.4, 1.4, (2, 100)).astype(np.float32)
    from mitnerf.fields.lattice import corner_weights, interpolate

    for p, res in ((params, 9), (big, 33)):
        corners, _ = corner_weights([Float(pts[0]), Float(pts[1])], [-1.5] * 2, [1.5] * 2, [res] * 2)
        val = np.asarray(interpolate(p["density"], 1, corners)[0])
        np.testing.assert_allclose(val, 0.3 * pts[0] - 0.2 * pts[1] + 0.1, atol=1e-5)


def test_a_box_lattice_with_uneven_cells_interpolates_its_vertices():
    # box x in [0, 2], y in [-1, 1]; cells (1, 0.5): 5 vertices along x (0, 0.5, .., 2), 3 along y (-1, 0, 1); raw
    # density g = 0.3 x - 0.2 y + 0.1 at the vertices (stored x fastest), read back exactly anywhere inside (bilinear
    # is exact on a linear function): g(0.75, 0.5) = 0.225 - 0.1 + 0.1 = 0.225; 0 outside the box (x = -0.5)
    cfg = GridConfig(dim=2, resolution=5, box=(0, -1, 2, 1), cells=(1, 0.5), density_scale=1.0,
                     density_activation="relu", bound=2.0)
    f = GridField(cfg)
    assert cfg.lattice(5) == [5, 3] and cfg.lattice(9) == [9, 5]
    assert f.init_numpy(0)["density"].shape == (3, 5)                    # numpy order: y, x
    X, Y = np.meshgrid(np.linspace(0, 2, 5), np.linspace(-1, 1, 3))
    params = {"density": Float((0.3 * X - 0.2 * Y + 0.1).ravel().astype(np.float32)),
              "color": Float(np.zeros(15 * 3, np.float32))}
    pts = [Float([0.75, 1.9, 0.1, -0.5]), Float([0.5, -0.95, 0.0, 0.0])]
    want = [0.225, 0.3 * 1.9 + 0.2 * 0.95 + 0.1, 0.13, 0.0]
    np.testing.assert_allclose(np.asarray(f.density(params, pts)), want, atol=2e-5)   # fp32
    big = f.resize(params, 9)                                            # coarse to fine: 9 x 5, same function
    assert dr.width(big["density"]) == 45 and f.resolution_of(big) == 9 and f.to_numpy(big)["density"].shape == (5, 9)
    np.testing.assert_allclose(np.asarray(f.density(big, pts)), want, atol=2e-5)


def test_a_refined_density_lattice_has_k_cells_per_colour_cell_and_keeps_its_function():
    # the box of the test above, density_refine 2: colour 5 x 3 vertices, density 2 (5 - 1) + 1 = 9 by 2 (3 - 1) + 1
    # = 5; the same linear raw density g = 0.3 x - 0.2 y + 0.1 on the density lattice reads back exactly; resized to
    # 9 colour vertices a side: colour 9 x 5, density 17 x 9, the function unchanged
    cfg = GridConfig(dim=2, resolution=5, box=(0, -1, 2, 1), cells=(1, 0.5), density_scale=1.0,
                     density_activation="relu", bound=2.0, density_refine=2)
    f = GridField(cfg)
    assert cfg.density_lattice(5) == [9, 5] and cfg.density_lattice(9) == [17, 9]
    init = f.init_numpy(0)
    assert init["density"].shape == (5, 9) and init["color"].shape == (3, 5, 3)
    X, Y = np.meshgrid(np.linspace(0, 2, 9), np.linspace(-1, 1, 5))
    params = {"density": Float((0.3 * X - 0.2 * Y + 0.1).ravel().astype(np.float32)),
              "color": Float(np.zeros(15 * 3, np.float32))}
    assert f.resolution_of(params) == 5 and f.density_shape_of(params) == [9, 5]
    pts = [Float([0.75, 1.9, 0.1, -0.5]), Float([0.5, -0.95, 0.0, 0.0])]
    want = [0.225, 0.3 * 1.9 + 0.2 * 0.95 + 0.1, 0.13, 0.0]
    np.testing.assert_allclose(np.asarray(f.density(params, pts)), want, atol=2e-5)   # fp32
    big = f.resize(params, 9)
    assert dr.width(big["density"]) == 17 * 9 and dr.width(big["color"]) == 9 * 5 * 3
    assert f.to_numpy(big)["density"].shape == (9, 17) and f.resolution_of(big) == 9
    np.testing.assert_allclose(np.asarray(f.density(big, pts)), want, atol=2e-5)


def test_a_refined_grid_resizes_as_its_twin_and_refuses_what_fits_no_lattice():
    """The box of the parity test below, density_refine 2, from 5 to 9 colour vertices a side: both engines
    resample both lattices to the same values; a density array of the wrong size, a colour one that is not whole
    vertices, and a density lattice over 1025 a side are refused, each with its fix."""
    torch = pytest.importorskip("torch")
    from mitnerf.errors import CheckpointError, ConfigError
    from mitnerf.reference.fields.grid import GridField as TwinGrid

    cfg = GridConfig(dim=3, resolution=9, initial_resolution=5, upsample_at=(1,), view_dependent=True,
                     box=(-1.2, -0.9, -1.0, 1.1, 1.3, 0.8), cells=(1.0, 0.6, 0.8), density_refine=2)
    f, twin = GridField(cfg), TwinGrid(cfg)
    rng = np.random.default_rng(3)
    arrays = {k: rng.normal(size=v.shape).astype(np.float32) for k, v in f.init_numpy(0).items()}
    big = f.to_numpy(f.schedule(1, f.from_numpy(arrays)))
    twin.load_numpy(arrays)
    assert twin.schedule(1) and not twin.schedule(1)
    for k, v in twin.to_numpy().items():
        assert big[k].shape == v.shape
        np.testing.assert_allclose(big[k], v, atol=1e-6)
    assert big["density"].shape[::-1] == tuple(2 * (n - 1) + 1 for n in cfg.lattice(9))
    with pytest.raises(CheckpointError, match="another configuration"):
        f.resolution_of(f.from_numpy({**arrays, "density": arrays["density"][:-1]}))
    with pytest.raises(CheckpointError, match="another configuration"):
        f.resolution_of(f.from_numpy({**arrays, "color": arrays["color"].ravel()[:-1]}))
    with pytest.raises(ConfigError, match="choose a smaller density_refine"):
        GridConfig(dim=3, resolution=513, density_refine=3)


def test_box_grids_pass_the_backend_checks():
    """A 3D box off centre with uneven cells: every Dr.Jit path against the torch twin and finite differences."""
    from mitnerf.reference.parity import check_parity

    box = dict(box=(-1.2, -0.9, -1.0, 1.1, 1.3, 0.8), cells=(1.0, 0.6, 0.8))
    assert check_parity("grid", 3, rays=24, samples=12, fine=0, field_args=box).ok
    assert check_parity("grid", 3, rays=24, samples=12, fine=0, field_args={**box, "density_refine": 2}).ok
    assert check_parity("grid", 3, rays=24, samples=12, fine=0, field_args={**box, "view_color": "grey"}).ok


def test_grey_harmonics_add_one_shared_term_to_each_channel_in_both_engines():
    """Degree 1, grey: a vertex holds 3 + 3 floats, the channels' degree-0 terms (0.1, -0.2, 0.3) and one set of
    band-1 weights (0.5, 0, -1). Towards d = (0.6, 0, 0.8) the shared term is 0.5 * 0.6 - 1 * 0.8 = -0.5, so the
    colour is sigmoid((-0.4, -0.7, -0.2)) = (0.4013, 0.3318, 0.4502)."""
    torch = pytest.importorskip("torch")
    from mitnerf.fields.harmonics import harmonic_rgb
    from mitnerf.reference.fields.harmonics import harmonic_rgb as twin_rgb

    raw, d = [0.1, -0.2, 0.3, 0.5, 0.0, -1.0], [0.6, 0.0, 0.8]
    got = harmonic_rgb([Float(v) for v in raw], [Float(v) for v in d], 4, 1, grey=True)
    assert np.allclose([c[0] for c in got], [0.4013, 0.3318, 0.4502], atol=1e-4)
    twin = twin_rgb(torch.tensor([raw]), torch.tensor([d]), 1, grey=True)
    assert np.allclose(twin.numpy()[0], [0.4013, 0.3318, 0.4502], atol=1e-4)


def test_a_grey_grid_keeps_the_rgb_lattice_in_half_the_colour_floats():
    from mitnerf.errors import ConfigError
    from mitnerf.fields.hashlinear import HashLinearConfig

    rgb = GridConfig(dim=3, resolution=9, view_dependent=True, density_refine=2)
    grey = GridConfig(dim=3, resolution=9, view_dependent=True, density_refine=2, view_color="grey")
    assert (rgb.color_floats, grey.color_floats) == (12, 6)
    assert grey.refined_share == rgb.refined_share                     # the same lattice when sized
    assert GridConfig(dim=3, resolution=9, view_color="grey").color_floats == 3     # no view dependence: RGB
    f = GridField(grey)
    arrays = f.init_numpy(0)
    assert arrays["color"].shape[-1] == 6 and f.resolution_of(f.from_numpy(arrays)) == 9
    with pytest.raises(ConfigError, match="view_color=rgb"):
        HashLinearConfig(dim=3, resolutions=(5, 9), view_color="grey")


def test_auto_sizing_gives_the_square_a_smaller_model_than_the_bunny():
    from mitnerf.data.cache import cached_dataset
    from mitnerf.data.rig import RigConfig
    from mitnerf.train.auto import AutoConfig, auto_size

    # validation PSNR at 33 / 65 vertices: the square 35.1 / 37.2 dB, the bunny 29.8 / 34.2 dB
    cfg = AutoConfig(target_psnr=32.0, steps=250, families=("grid",), time_budget=120)
    chosen = {}
    for scene in ("square", "bunny"):
        ds = cached_dataset(scene, RigConfig(dim=2, n_train=30, n_val=4, n_test=4, seed=0))
        result = auto_size(ds, cfg)
        chosen[scene] = result.model.field_args["resolution"]
        assert result.reasons and len(result.trials) >= 2
        # view dependence and each regulariser were probed on the chosen size, each with its reason
        notes = [t.note for t in result.trials]
        assert {"view dependence", "degree", "distortion_weight", "opacity_weight"} <= set(notes), notes
        assert any(r.startswith("distortion_weight = 0.001 ") for r in result.reasons), result.reasons
    assert chosen["square"] < chosen["bunny"], chosen


def test_auto_picks_the_smallest_size_near_the_best_probe():
    from mitnerf.train.auto import Trial, pick_size
    from mitnerf.train.recipes import recipe_for

    r = recipe_for("grid", 2)
    # probes smallest first: 30.0, 35.8, 36.0, 35.9 dB
    sized = [Trial(r, n, v, 10.0) for n, v in ((1_000, 30.0), (4_000, 35.8), (16_000, 36.0), (64_000, 35.9))]
    assert pick_size(sized, 0.3)[0].params == 4_000          # 35.8 >= 36.0 - 0.3: the smallest near the best
    assert pick_size(sized, 0.1)[0].params == 16_000         # only 36.0 and 35.9 are near; 16k is smaller
    assert pick_size(sized, 0.0)[2].startswith("the best of 4 probes")
    chosen, reached, why = pick_size(sized, 0.3, target=35.0)
    assert (chosen.params, reached) == (4_000, True)          # the first to reach 35 dB
    chosen, reached, why = pick_size(sized, 0.3, target=40.0)
    assert (chosen.params, reached) == (16_000, False) and "none reached 40.0 dB" in why


def test_auto_prints_each_probe_with_the_sizes_it_trained():
    """A probe of the default recipe names the lattice the data sized (225 vertices across), not the recipe's own."""
    from mitnerf.train.auto import Trial, trial_line
    from mitnerf.train.recipes import recipe_for

    r = recipe_for("grid", 3)
    line = trial_line(Trial(r, 10, 28.25, 120.0, "size", r.override(resolution=225, initial_resolution=57)))
    assert "resolution=225, initial_resolution=57" in line and line.endswith("28.25 dB in 120.0 s [size]"), line
    assert "resolution=129" in trial_line(Trial(r, 10, 28.25, 120.0, "size"))        # none: the recipe's own


def test_auto_switches_an_option_only_where_it_gains_the_threshold():
    from mitnerf.train.auto import switch

    assert switch(True, 0.06, 0.2) == (False, "kept")         # on in the recipe; off gains 0.06 dB: stays on
    assert switch(True, 0.3, 0.2) == (True, "dropped")
    assert switch(False, 0.1, 0.2) == (False, "left off")
    assert switch(False, 0.2, 0.2) == (True, "added")         # exactly the threshold is enough


def test_auto_switches_each_regulariser_on_at_a_weight_that_does_something():
    """``fit --auto`` switches a loss on at the dimension's default recipe's weight: never at 0, which would probe
    the recipe itself."""
    from mitnerf.train.auto import AutoConfig, regulariser_weights
    from mitnerf.train.recipes import recipe_for

    for dim in (2, 3):
        weights = dict(regulariser_weights(AutoConfig(), dim))
        assert set(weights) == set(AutoConfig().regularisers)
        assert all(w > 0 for w in weights.values()), (dim, weights)
        assert weights == {k: recipe_for(None, dim).get(k) for k in weights}
    # 2D's colour total variation is 1e-2, 3D's 3e-4: each dimension switches it on at its own weight
    assert dict(regulariser_weights(AutoConfig(), 3))["tv_color_weight"] < \
        dict(regulariser_weights(AutoConfig(), 2))["tv_color_weight"]


def test_auto_keeps_what_the_user_typed():
    """``fit --auto --lr 0.02 --time-budget 3``: the search picks the model, the user's settings still hold."""
    from mitnerf.data.cache import cached_dataset
    from mitnerf.data.rig import RigConfig
    from mitnerf.train.auto import AutoConfig, choose_recipe

    ds = cached_dataset("square", RigConfig(dim=2, n_train=8, n_val=2, n_test=2, resolution=32, seed=0))
    # one 20-step probe of the default recipe (grid-2d, 257 vertices a side), then the search budget is spent
    cfg = AutoConfig(steps=20, families=("grid",), time_budget=1e-3)
    chosen, reasons = choose_recipe(ds, cfg, {"lr": 0.02, "time_budget": 3.0})
    assert chosen.model.field == "grid" and chosen.model.field_args["resolution"] == 257, chosen.summary()
    assert chosen.model.field_args["view_dependent"] is True            # the recipe's own: never probed
    assert (chosen.train.lr, chosen.train.time_budget) == (0.02, 3.0)
    assert chosen.name == "auto:grid-2d+", chosen.name                    # a modified recipe says so
    assert any("not tried: the search budget is spent" in r for r in reasons), reasons
    assert "64 samples per ray not tried: the search budget is spent (kept 128)" in reasons, reasons


@pytest.mark.parametrize("field, dim", [("grid", 2), ("grid", 3), ("hashgrid", 2), ("hashgrid", 3), ("hashlinear", 2),
                                        ("hashlinear", 3)])
def test_grid_fields_pass_the_backend_checks(field, dim):
    from mitnerf.reference.parity import check_parity

    assert check_parity(field, dim, rays=24, samples=12, fine=8 if dim == 2 else 0).ok
