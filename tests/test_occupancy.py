"""The occupancy grid and its sampler: which bins it keeps, how it skips empty cells, the early stop, and the
samples a render takes against training's (against the torch twin and a sampler that steps bin by bin)."""

import drjit as dr
import numpy as np
import pytest
from drjit.auto.ad import Float, UInt32

from mitnerf.render.occupancy import OccupancyConfig, OccupancyGrid, OccupiedSampler, cell_index


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
