"""Grid and hash-grid fields, empty-space skipping, and auto-sizing."""

import drjit as dr
import numpy as np
import pytest
from drjit.auto.ad import Float, UInt32

from mitnerf.fields.grid import GridConfig, GridField
from mitnerf.fields.hashenc import hash_encode, hash_layout
from mitnerf.render.occupancy import OccupancyConfig, OccupancyGrid, OccupiedSampler, cell_index


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


def test_occupancy_keeps_every_sample_with_density():
    """A known field, dense in a checkerboard of occupancy cells: after one update exactly
    those cells are occupied, and a ray's samples land in every bin whose density exceeds
    the threshold and in no other."""
    cfg = OccupancyConfig(enabled=True, resolution=8, warmup=0, threshold=0.01, march_bins=64)
    grid = OccupancyGrid(cfg, 2, bound=1.0)

    def density(x):                                    # 5 in cells (i + j) even, 0 elsewhere
        cell, inside = cell_index(x, 1.0, 8)
        checker = ((cell % 8) + (cell // 8)) % 2 == 0
        return dr.select(inside & checker, 5.0, 0.0)

    grid.update(density, step=0, seed=3)
    occ = np.asarray(grid.occupied).reshape(8, 8)
    i, j = np.meshgrid(np.arange(8), np.arange(8))
    np.testing.assert_array_equal(occ, ((i + j) % 2 == 0).astype(np.float32))
    # rays along x at several heights: 64 bins over [0, 2] from x = -1; 32 occupied bins at most
    n_rays = 5
    ys = np.array([-0.9, -0.4, 0.05, 0.3, 0.8], np.float32)
    o = [Float(np.full(n_rays, -1.0, np.float32)), Float(ys)]
    d = [Float(np.ones(n_rays, np.float32)), Float(np.zeros(n_rays, np.float32))]
    sampler = OccupiedSampler(*grid.lookup, 32, 64, 1.0, 8, UInt32(1), jitter=True)
    ex = sampler.build(o, d, 0.0, 2.0)
    t = np.asarray(ex.t_flat).reshape(n_rays, 32)
    delta = np.asarray(ex.delta_flat).reshape(n_rays, 32)
    np.testing.assert_array_equal(np.asarray(ex.count), (delta > 0).sum(1))      # the integral stops there
    for r in range(n_rays):
        mids = (np.arange(64) + 0.5) / 32.0
        x_mid = -1.0 + mids
        dens = np.asarray(density([Float(x_mid.astype(np.float32)), Float(np.full(64, ys[r], np.float32))]))
        wanted = set(np.flatnonzero(dens > 0.01))
        used = t[r][delta[r] > 0]
        got = set(np.floor(used * 32.0).astype(int))
        assert got == wanted                            # every dense bin, and only those
        np.testing.assert_allclose(delta[r][delta[r] > 0], 1 / 32.0)


def test_the_sampler_looks_only_inside_the_box_of_occupied_cells():
    """One occupied cell of a 4 x 4 grid over [-1, 1]^2, cell (2, 1): x in [0, 0.5], y in [-0.5, 0]. The box is that
    cell; a ray through it gets the samples of its bins (16 bins of 0.125 over [0, 2] from x = -1: bins 8..11, at
    x -1 + 0.125 (k + 0.5), inside [0, 0.5) for k = 8, 9, 10, 11), a ray that misses it none, as without the box."""
    cfg = OccupancyConfig(enabled=True, resolution=4, warmup=0, threshold=0.01, march_bins=16)
    grid = OccupancyGrid(cfg, 2, bound=1.0)
    grid.update(lambda x: dr.select((x[0] > 0) & (x[0] < 0.5) & (x[1] > -0.5) & (x[1] < 0), 5.0, 0.0), 0, 0)
    np.testing.assert_allclose(np.asarray(grid.box), [0.0, -0.5, 0.5, 0.0])
    o = [Float([-1.0, -1.0]), Float([-0.25, 0.75])]
    d = [Float([1.0, 1.0]), Float([0.0, 0.0])]
    whole = (grid.occupied, Float([-1.0, -1.0, 1.0, 1.0]))           # a box around the whole grid
    got, every = (OccupiedSampler(*lookup, 8, 16, 1.0, 4, UInt32(0), jitter=False, grouped=g).build(o, d, 0.0, 2.0)
                  for lookup, g in ((grid.lookup, True), (whole, False)))     # the rays grouped by their bins, or not
    np.testing.assert_array_equal(np.asarray(got.count), [4, 0])
    np.testing.assert_array_equal(np.asarray(got.t_flat)[:4], 0.125 * (np.arange(8, 12) + 0.5))
    for a, b in ((got.t_flat, every.t_flat), (got.delta_flat, every.delta_flat), (got.count, every.count)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_early_stop_gives_a_thick_objects_front_the_samples_in_both_engines():
    """A ray along x from x = -1 through a grid occupied everywhere, density 10 everywhere: 20 bins of 0.1 over
    [0, 2], each of optical depth 1. With early_stop e^-3.5 the march takes bins while the optical depth in front
    of them is under 3.5: bins 0, 1, 2, 3 (depth in front 0, 1, 2, 3; bin 4 has 4). Two slots: stride 2, samples
    at the centres of bins 0 and 2 (t = 0.05, 0.25), each for 0.2. Without it: 20 bins, stride 10, samples at
    bins 0 and 10 (t = 0.05, 1.05), each for 1.0. The torch twin places the same."""
    import torch

    from mitnerf.reference.render.occupancy import OccupancyGrid as TwinGrid, occupied_samples

    cfg = OccupancyConfig(enabled=True, resolution=2, march_bins=20)
    lookup = OccupancyGrid(cfg, 2, bound=1.0).lookup                  # every cell occupied before an update
    o, d = [Float([-1.0]), Float([0.0])], [Float([1.0]), Float([0.0])]
    for early_stop, t, delta in ((np.exp(-3.5), [0.05, 0.25], [0.2, 0.2]), (0.0, [0.05, 1.05], [1.0, 1.0])):
        ex = OccupiedSampler(*lookup, 2, 20, 1.0, 2, UInt32(0), jitter=False, density=lambda x: 10.0 + 0.0 * x[0],
                             early_stop=early_stop).build(o, d, 0.0, 2.0)
        np.testing.assert_allclose(np.asarray(ex.t_flat), t, rtol=1e-5)
        np.testing.assert_allclose(np.asarray(ex.delta_flat), delta, rtol=1e-5)
        np.testing.assert_array_equal(np.asarray(ex.count), [2])
        twin = occupied_samples(TwinGrid(cfg, 2, 1.0), torch.tensor([[-1.0, 0.0]]), torch.tensor([[1.0, 0.0]]),
                                0.0, 2.0, 2, 0, False, density=lambda x: torch.full((x.shape[0],), 10.0),
                                early_stop=early_stop)
        np.testing.assert_allclose(twin.t.numpy().ravel(), t, rtol=1e-5)
        np.testing.assert_allclose(twin.delta.numpy().ravel(), delta, rtol=1e-5)


def test_early_stop_places_the_same_samples_in_both_engines_and_ends_rays_in_a_dense_blob():
    """Random rays through a dense blob (density 40 exp(-|x|^2 / 0.1)), jittered: the engines place the same samples
    with early_stop 1e-2, and the rays that cross the blob's core get theirs in front of it, more finely than
    without it."""
    import torch

    from mitnerf.reference.render.occupancy import OccupancyGrid as TwinGrid, occupied_samples

    cfg = OccupancyConfig(enabled=True, resolution=16, warmup=0, march_bins=128)
    grid, twin_grid = OccupancyGrid(cfg, 2, bound=1.0), TwinGrid(cfg, 2, 1.0)
    grid.update(lambda x: 40.0 * dr.exp(-(x[0] * x[0] + x[1] * x[1]) * 10.0), 0, 0)
    twin_grid.load(grid.state())
    rng = np.random.default_rng(0)
    angle = rng.uniform(0, 2 * np.pi, 64)
    o = np.stack([1.8 * np.cos(angle), 1.8 * np.sin(angle)], 1).astype(np.float32)
    aim = rng.uniform(-0.4, 0.4, (64, 2)).astype(np.float32)
    d = (aim - o) / np.linalg.norm(aim - o, axis=1, keepdims=True)
    counts = []
    for early_stop in (1e-2, 0.0):
        ex = OccupiedSampler(*grid.lookup, 16, 128, 1.0, 16, UInt32(5), jitter=True, early_stop=early_stop,
                             density=lambda x: 40.0 * dr.exp(-(x[0] * x[0] + x[1] * x[1]) * 10.0)).build(
            [Float(o[:, 0]), Float(o[:, 1])], [Float(d[:, 0]), Float(d[:, 1])], 0.5, 3.5)
        twin = occupied_samples(twin_grid, torch.from_numpy(o), torch.from_numpy(d), 0.5, 3.5, 16, 5, True,
                                density=lambda x: 40.0 * torch.exp(-(x ** 2).sum(1) * 10.0), early_stop=early_stop)
        np.testing.assert_allclose(np.asarray(ex.t_flat).reshape(64, 16), twin.t.numpy(), rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(np.asarray(ex.delta_flat).reshape(64, 16), twin.delta.numpy(), rtol=1e-5,
                                   atol=1e-6)
        last = np.asarray(ex.t_flat).reshape(64, 16)[np.arange(64), np.asarray(ex.count) - 1]
        counts.append((np.asarray(ex.delta_flat).reshape(64, 16).max(1), last))
    (fine, last_stop), (coarse, last_all) = counts
    through = np.abs(o[:, 0] * d[:, 1] - o[:, 1] * d[:, 0]) < 0.15       # rays that pass within 0.15 of the centre
    assert through.sum() >= 10
    assert np.all(fine[through] < coarse[through]) and np.all(last_stop[through] < 1.8)
    assert np.all(last_all[through] > 1.8)                 # without it, the samples reach past the blob's centre


def test_the_sampler_crosses_empty_cells_in_one_step_yet_places_the_samples_of_every_bin():
    """A patchy 3D grid (8^3 cells, about a third occupied: empty cells beside occupied ones on every axis) and 200
    random rays through it, 96 bins each (about 5 a cell): the sampler, which crosses an empty cell in one step,
    places the samples of the torch twin, which looks every bin up. With 96 slots (stride 1: the renders' single
    pass), with 8 (stride > 1, the second pass, which steps bin by bin) and with an early stop (training's count)."""
    import torch

    from mitnerf.reference.render.occupancy import OccupancyGrid as TwinGrid, occupied_samples

    def patches(x, sin, where):
        return where(sin(7.0 * x[0] + 1.0) * sin(5.0 * x[1]) * sin(3.0 * x[2] + 0.5) > 0.2, 30.0, 0.0)

    cfg = OccupancyConfig(enabled=True, resolution=8, warmup=0, march_bins=96)
    grid, twin_grid = OccupancyGrid(cfg, 3, bound=1.0), TwinGrid(cfg, 3, 1.0)
    grid.update(lambda x: patches(x, dr.sin, dr.select), 0, 0)
    twin_grid.load(grid.state())
    assert 0.2 < np.mean(np.asarray(grid.occupied)) < 0.5
    rng = np.random.default_rng(4)
    o = rng.normal(size=(200, 3)).astype(np.float32)
    o = 2.5 * o / np.linalg.norm(o, axis=1, keepdims=True)
    d = rng.uniform(-0.7, 0.7, (200, 3)).astype(np.float32) - o
    d = (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)
    O, D = [Float(o[:, a]) for a in range(3)], [Float(d[:, a]) for a in range(3)]
    for n, jitter, early_stop in ((96, False, 0.0), (8, True, 0.0), (16, True, 1e-2)):
        ex = OccupiedSampler(*grid.lookup, n, 96, 1.0, 8, UInt32(2), jitter=jitter, early_stop=early_stop,
                             density=lambda x: patches(x, dr.sin, dr.select)).build(O, D, 1.0, 4.5)
        twin = occupied_samples(twin_grid, torch.from_numpy(o), torch.from_numpy(d), 1.0, 4.5, n, 2, jitter,
                                density=lambda x: patches(x.T, torch.sin, torch.where), early_stop=early_stop)
        count = np.asarray(ex.count)
        assert count.max() > 1 and (n != 8 or count.max() == n)
        np.testing.assert_allclose(np.asarray(ex.t_flat).reshape(200, n), twin.t.numpy(), rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(np.asarray(ex.delta_flat).reshape(200, n), twin.delta.numpy(), rtol=1e-5,
                                   atol=1e-6)


class SteppingSampler(OccupiedSampler):
    """The sampler looking every bin up (no cell crossed in one step)."""

    def _faces(self, d, dt):
        return None


def test_rays_nearly_along_a_cell_face_or_starting_in_the_grid_skip_no_occupied_bin():
    """Two occupied cells of an 8^3 grid over [-1, 1]^3: (3, 4, 4) (x in [-0.25, 0], y, z in [0, 0.25]) and (7, 0, 0).
    Rays along z that drift across the face x = 0 by 4e-8 to 1e-5 a unit (so within a cell of it: one direction
    component tiny, where an exit computed far from the ray's point would cancel two large numbers), crossing it at
    19 points along the occupied cell; and 100 random rays from inside the grid (near 0). Each places the samples of
    the sampler that looks every bin up."""
    occupied = np.zeros(8 ** 3, np.float32)
    occupied[[3 + 8 * 4 + 64 * 4, 7]] = 1.0
    box = Float([-0.25, -1.0, -1.0, 1.0, 0.25, 0.25])
    rows = [(np.array([-dx * (2.5 + 0.25 * f), 0.1, -2.5]), np.array([dx, 0.0, 1.0]))
            for dx in (-4e-8, -1e-7, -3e-7, -1e-6, -1e-5) for f in np.linspace(0.05, 0.95, 19)]
    rng = np.random.default_rng(3)
    inner = rng.uniform(-0.9, 0.9, (100, 3))
    aim = rng.normal(size=(100, 3))
    for o, d, near, far in ((np.array([r[0] for r in rows]), np.array([r[1] for r in rows]), 1.0, 4.5),
                            (inner, aim / np.linalg.norm(aim, axis=1, keepdims=True), 0.0, 3.5)):
        O, D = ([Float(v[:, a].astype(np.float32)) for a in range(3)] for v in (o, d))
        got, every = (S(Float(occupied), box, 96, 96, 1.0, 8, UInt32(0), jitter=False).build(O, D, near, far)
                      for S in (OccupiedSampler, SteppingSampler))
        assert np.asarray(every.count).max() >= 2
        for a, b in ((got.count, every.count), (got.t_flat, every.t_flat), (got.delta_flat, every.delta_flat)):
            np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


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


@pytest.mark.parametrize("oversample", [1, 2])
def test_a_render_takes_render_oversample_times_the_samples_and_training_does_not(oversample):
    """16 bins over [0, 2] (dt 0.125) and 8 samples, every cell occupied (no update yet), a ray along x from -1: a
    render groups the 16 occupied bins by 2, one sample at the centre of each group's first bin, t = 0.0625 + 0.25 j,
    delta 0.25; with ``render_oversample`` 2, 16 samples on the same 16 bins: one a bin, t = 0.0625 + 0.125 k,
    delta 0.125; the same in the torch twin. A training step keeps 8 samples of 2 bins whatever the setting."""
    import torch

    from mitnerf.reference.render.occupancy import OccupancyGrid as TorchOccupancy
    from mitnerf.render.pipeline import RenderConfig
    from mitnerf.train.backend_drjit import build_model
    from mitnerf.train.backend_torch import build_torch_model
    from mitnerf.train.config import ModelConfig

    occ = OccupancyConfig(enabled=True, resolution=4, warmup=0, march_bins=16)
    mc = ModelConfig("grid", dict(resolution=5), RenderConfig(n_coarse=8, occupancy=occ, render_oversample=oversample))
    n = 8 * oversample
    want_t = 0.0625 + np.arange(n) * (2.0 / n)
    model = build_model(mc, 2, 1.0)
    params = model.init_params(0)
    o, d = [Float([-1.0]), Float([0.0])], [Float([1.0]), Float([0.0])]
    grid = OccupancyGrid(occ, 2, 1.0)
    for training, size in ((False, n), (True, 8)):
        t, delta = model.render(params, o, d, 0.0, 2.0, UInt32(0), training=training, weights=True,
                                occupancy=grid.lookup)["samples"]
        assert dr.width(t) == size
        np.testing.assert_allclose(np.asarray(delta), 2.0 / size, rtol=1e-6)
    t, delta = model.render(params, o, d, 0.0, 2.0, UInt32(0), training=False, weights=True,
                            occupancy=grid.lookup)["samples"]
    np.testing.assert_allclose(np.asarray(t), want_t, rtol=1e-6)
    twin = build_torch_model(mc, 2, 1.0)
    twin.load_numpy(model.to_numpy(params))
    tt, td = twin.render(torch.tensor([[-1.0, 0.0]]), torch.tensor([[1.0, 0.0]]), 0.0, 2.0, 0, training=False,
                         weights=True, occupancy=TorchOccupancy(occ, 2, 1.0))["samples"]
    np.testing.assert_allclose(tt.numpy().ravel(), want_t, rtol=1e-6)
    np.testing.assert_allclose(td.numpy().ravel(), 2.0 / n, rtol=1e-6)
    tt, td = twin.render(torch.tensor([[-1.0, 0.0]]), torch.tensor([[1.0, 0.0]]), 0.0, 2.0, 0, training=True,
                         weights=True, occupancy=TorchOccupancy(occ, 2, 1.0))["samples"]
    assert tt.numel() == 8 and np.allclose(td.numpy(), 2.0 / 8)
