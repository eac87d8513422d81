"""The dense grid's total variation: by hand, its vertex block, and its torch twin (value and gradient)."""

import drjit as dr
import numpy as np
import pytest
from drjit.auto.ad import UInt32

from mitnerf.fields.grid import GridConfig, GridField, tv_vertices


def test_total_variation_of_a_ramp_by_hand():
    # a 3 x 3 density grid (x fastest) holding x index 0, 1, 2 in every row: along x each of the 6 vertices
    # with a right neighbour differs by 1, along y nothing differs; the mean over all 9 vertices is 6 / 9,
    # times density_scale^2 = 4 and tv_weight = 0.5: 0.5 * 4 * 6 / 9 = 1.3333
    f = GridField(GridConfig(dim=2, resolution=3, tv_weight=0.5, density_scale=2.0, tv_samples=0))
    arrays = f.init_numpy(0)
    arrays["density"] = np.tile(np.arange(3, dtype=np.float32), (3, 1))
    value = f.regularizer(f.from_numpy(arrays), UInt32(7))
    assert float(value[0]) == pytest.approx(0.5 * 4 * 6 / 9, rel=1e-6)


def test_a_sampled_step_takes_consecutive_distinct_vertices():
    wrapped = 0
    for seed in range(20):          # 5 of 7 vertices from a random start: some steps wrap past the last one
        v = np.asarray(tv_vertices(UInt32(seed), 5, 7)).astype(np.int64)
        assert len(set(v.tolist())) == 5 and all((b - a) % 7 == 1 for a, b in zip(v[:-1], v[1:]))
        wrapped += int(v[-1] < v[0])
    assert 0 < wrapped < 20
    np.testing.assert_array_equal(np.asarray(tv_vertices(UInt32(3), 0, 7)), np.arange(7))     # 0: the whole grid
    np.testing.assert_array_equal(np.asarray(tv_vertices(UInt32(3), 9, 7)), np.arange(7))     # more than there are


BOX = dict(box=(-1.0, -0.5, -1.5, 1.0, 0.5, 0.5), cells=(1.0, 0.5, 0.75))     # 9 x 5 x 7 vertices


@pytest.mark.parametrize("dim, samples, box", [(2, 0, {}), (2, 40, {}), (3, 100, {}), (3, 60, BOX),
                                               (3, 60, {**BOX, "density_refine": 2}), (2, 40, {"sh_degree": 2}),
                                               (3, 60, {"sh_degree": 2})])
def test_total_variation_twin_agrees(dim, samples, box):
    # the same random grids in both engines, the same step seed: equal value and equal gradients
    torch = pytest.importorskip("torch")
    from mitnerf.reference.fields.grid import GridField as TwinGrid

    cfg = GridConfig(dim=dim, resolution=9 if dim == 2 or box else 5, view_dependent=True, tv_weight=1e-2,
                     tv_color_weight=0.3, tv_samples=samples, **box)
    f, twin = GridField(cfg), TwinGrid(cfg)
    rng = np.random.default_rng(1)
    arrays = {k: rng.normal(size=v.shape).astype(np.float32) for k, v in f.init_numpy(0).items()}
    params = f.from_numpy(arrays)
    dr.enable_grad(params)
    value = f.regularizer(params, UInt32(11))
    dr.backward(value)
    twin.load_numpy(arrays)
    tv = twin.regularizer(11)
    tv.backward()
    assert float(value[0]) == pytest.approx(float(tv.detach()), rel=1e-5)
    grads = f.to_numpy({k: dr.grad(v) for k, v in params.items()})       # without the colour's pad floats
    np.testing.assert_allclose(grads["density"].ravel(), twin.density_grid.grad.numpy().ravel(), rtol=1e-4, atol=1e-7)
    np.testing.assert_allclose(grads["color"].ravel(), twin.color_grid.grad.numpy().ravel(), rtol=1e-4, atol=1e-7)
